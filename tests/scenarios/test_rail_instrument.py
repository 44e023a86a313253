"""The seam (issue 60): an instrument that exists only in the tests (tests/instruments/rail: a
one-axis stage with a scale error and lost motion) is registered with one line and goes through
``run``, ``montecarlo``, ``discover`` and the suites by the command line and the suites' own
functions, nothing of the product changed for it."""

import json

import numpy as np
import pytest

from calibench.scenarios import registry
from calibench.scenarios.cli import main
from tests.conftest import REPO


@pytest.fixture(scope="module")
def rail():
    """The rail registered for this module's tests alone, and taken out after them, so no other
    test of this process sees a ``rail`` (tests/scenarios/test_registry.py checks that none is
    registered)."""
    import tests.instruments.rail as package
    import tests.instruments.rail.scenario  # noqa: F401 - package.scenario for the tests

    registry.register(package.INSTRUMENT)  # imported before by another module: its line again
    yield package
    registry.unregister(package.INSTRUMENT.name)


@pytest.fixture(scope="module")
def run_dir(rail, tmp_path_factory):
    """``calibench run rail --no-rrd``'s folder."""
    out = tmp_path_factory.mktemp("rail") / "run"
    assert main(["run", "rail", "--out", str(out), "--no-rrd"]) == 0
    return out


def test_run_estimates_the_twin_s_own_truth(run_dir):
    report = json.loads((run_dir / "report.json").read_text())
    assert report["ok"] and report["scenario"] == "rail"
    params = {p["name"]: p for p in report["parameters"]}
    assert set(params) == {"offset", "scale", "lost_motion"}
    for p in params.values():  # each within 4 of its own std of the twin's truth
        assert abs(p["estimate"] - p["truth"]) < 4 * p["std"], p
    # the twin's lost motion is its own (MuJoCo's soft friction), near but not 2 F / K
    ratio = params["lost_motion"]["truth"] / report["info"]["lost_motion_2f_over_k_um"]
    assert 0.7 < ratio < 1.05, ratio
    assert (run_dir / "recording.csv").read_text().startswith("x_cmd_mm,x_meas_mm,dir_x,run")


def test_montecarlo_runs_in_spawned_workers(rail, tmp_path, monkeypatch):
    # a spawned worker imports the registry afresh: the environment names the rail for it
    monkeypatch.setenv("CALIBENCH_INSTRUMENTS", "tests.instruments.rail")
    monkeypatch.setenv("PYTHONPATH", str(REPO))
    out = tmp_path / "mc"
    assert main(["montecarlo", "rail", "--trials", "8", "--workers", "2", "--out", str(out)]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["trials"] == 8 and summary["failed"] == 0
    assert {p["name"] for p in summary["parameters"]} == {"offset", "scale", "lost_motion"}


def test_discover_finds_the_run_s_lost_motion_and_scale(rail, run_dir, tmp_path):
    truth = {
        p["name"]: p["truth"]
        for p in json.loads((run_dir / "report.json").read_text())["parameters"]
    }
    twin = tmp_path / "twin.toml"
    status = main(
        ["discover", "rail", str(run_dir / "recording.csv"), "--out", str(tmp_path / "d")]
        + ["--twin", str(twin)]
    )
    assert status == 0
    found = json.loads((tmp_path / "d" / "discovery.json").read_text())
    effects = {e["name"]: e for e in found["effects"]}
    assert set(effects) == {"backlash", "positioning"}, found["effects"]
    b = effects["backlash"]
    want = -truth["lost_motion"] / 1000  # the reversal: forward minus backward, mm
    off = abs(b["params"]["reversal_mm"] - want)
    assert off <= max(3 * b["stderr"]["reversal_mm"], 0.25 * abs(want)), (b, want)
    s = effects["positioning"]
    assert abs(s["params"]["scale_ppm"] - truth["scale"]) <= 3 * s["stderr"]["scale_ppm"]
    assert found["verdict"].startswith("the accepted effects explain")
    # the twin written back carries the friction the run's twin had (within 10 %)
    written = twin.read_text()
    friction = float(written.split("friction_n = ")[1].split()[0])
    assert abs(friction / rail.scenario.RailConfig().truth.friction_n - 1) < 0.1, written


@pytest.mark.usefixtures("rail")
def test_the_suites_score_the_rail_s_concealed_recordings():
    from calibench.scenarios.discover.suite import run_case, suite_cases

    cases = suite_cases()
    assert ("rail", "null", 0) in cases and ("rail", "backlash", 0) in cases
    hit = run_case("rail", "backlash", 0)
    assert hit.detected == hit.concealed == 1 and hit.false_claims == 0, hit
    assert all(err <= limit for _, err, limit in hit.param_errors), hit.param_errors
    null = run_case("rail", "null", 0)
    assert null.found == [] and null.false_claims == 0, null


@pytest.mark.usefixtures("rail")
@pytest.mark.parametrize("verb", ["run", "montecarlo", "discover"])
def test_the_command_line_lists_the_rail(verb, capsys):
    assert main([verb, "--help"]) == 0
    assert "rail" in capsys.readouterr().out


def test_a_run_reads_like_the_estimator_s_model(rail):
    """The twin is linear in the command and its lost motion the same at every station: the
    estimator's model is the twin's behaviour, not an approximation the tolerances hide."""
    cfg = rail.scenario.RailConfig()
    rec, x_true = rail.scenario.record(cfg, 0)
    fw, bw = x_true[rec.dir_x > 0], x_true[rec.dir_x < 0]
    gap = (bw.reshape(cfg.passes, -1)[:, ::-1] - fw.reshape(cfg.passes, -1)) * 1000
    assert np.ptp(gap) < 0.01 * abs(gap.mean()), gap  # um, every station and pass alike
