"""``calibench uncertainty``'s study (issue 64) on a task whose law is known
(tests/scenarios/uncertainty_linear_task.py: y = A x, x Gaussian): the adaptive procedure stops
at its tolerance, its standard uncertainties are A's, the GUM framework agrees within the
tolerance, fresh draws fall in the 95 % intervals 95 % of the time, and an interrupted study
resumes from its journal to the very same numbers."""

import json

import numpy as np
import pytest

from calibench.scenarios import uncertainty
from calibench.scenarios.cli import main
from tests.scenarios import uncertainty_linear_task as linear

U_TRUE = np.sqrt((linear.A**2) @ linear.S**2)  # each quantity's standard deviation


@pytest.fixture()
def linear_task(monkeypatch):
    monkeypatch.setattr(uncertainty, "task_of", lambda scenario: linear)
    monkeypatch.setattr(uncertainty, "FRESH_MACHINES", 2000)


def _study(out, *extra):
    argv = ["uncertainty", "arm-cmm", "--workers", "1", "--tolerance", "1", "--out", str(out)]
    argv += list(extra)
    assert main(argv) == 0
    return json.loads((out / "uncertainty.json").read_text())


def test_the_study_states_the_law_it_samples(tmp_path, linear_task):
    r = _study(tmp_path / "u")
    assert r["stopped"] == "tolerance" and r["trials"] % uncertainty.BATCH == 0, r["status"]
    u = np.array([g["u"] for g in r["grid"]])
    delta = r["tolerance"]["delta"]
    # the Monte Carlo's u within its own tolerance of the law's (a few of its numerical std)
    np.testing.assert_allclose(u, U_TRUE, atol=2 * delta)
    gum = np.array([g["gum_u"] for g in r["grid"]])
    np.testing.assert_allclose(gum, U_TRUE, rtol=1e-12)
    v = r["gum_validation"]
    assert v["worst_d_low"] < 2 * delta and v["worst_d_high"] < 2 * delta, v
    # 2000 fresh draws of 6 quantities: 0.95 within 4 of the binomial's std (its 12,000 values
    # are correlated in pairs at most, so sqrt(0.95 0.05 / 2000) bounds it)
    inside = r["coverage_check"]["fraction_inside_95"]
    assert abs(inside - 0.95) < 4 * np.sqrt(0.95 * 0.05 / 2000), inside
    from calibench.scenarios.rrlog import entity_paths

    assert {"/world/uncertainty/u", "/report"} <= entity_paths(tmp_path / "u" / "uncertainty.rrd")


def test_an_interrupted_study_resumes_to_the_same_numbers(tmp_path, linear_task):
    whole = _study(tmp_path / "whole")
    out = tmp_path / "cut"
    _study(out)
    journal = (out / uncertainty.JOURNAL).read_text().splitlines()
    # the journal cut after 250 trials and a torn line: what an interrupted study leaves
    (out / uncertainty.JOURNAL).write_text("\n".join(journal[:250]) + '\n{"study": "x", "ba')
    (out / "uncertainty.json").unlink()
    again = _study(out)
    assert again["grid"] == whole["grid"] and again["trials"] == whole["trials"]
    rows = [json.loads(x) for x in (out / uncertainty.JOURNAL).read_text().splitlines()[:250]]
    assert len(rows) == 250


def test_a_journal_of_another_seed_is_not_taken_for_this_studys(tmp_path, linear_task):
    """Two studies in one directory: the second (another seed) journals beside the first and
    draws every trial itself: its result is the one it makes alone."""
    alone = _study(tmp_path / "alone", "--seed", "1")
    out = tmp_path / "shared"
    _study(out)
    beside = _study(out, "--seed", "1")
    assert beside["grid"] == alone["grid"] and beside["trials"] == alone["trials"]


def test_a_scenario_without_a_task_is_refused_in_one_line(tmp_path, capsys, monkeypatch):
    """An instrument whose registry line names no task (every one has one now: the line's field
    taken away) is refused in one line."""
    import dataclasses

    from calibench.scenarios import registry

    real = registry.instrument

    def without_task(name):
        row = real(name)
        return dataclasses.replace(row, uncertainty=None) if name == "stewart" else row

    monkeypatch.setattr(registry, "instrument", without_task)
    assert main(["uncertainty", "stewart", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no task is built for stewart" in err[0], err
