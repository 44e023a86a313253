"""stewart end to end through the CLI: 42 leg parameters, checks, both methods, the rrd."""

import dataclasses
import json

import numpy as np
import pytest

from calibench.scenarios.cli import main
from calibench.scenarios.rrlog import entity_paths


def test_run_meets_the_acceptance(tmp_path):
    assert main(["run", "stewart", "--seed", "0", "--out", str(tmp_path)]) == 0
    rep = json.loads((tmp_path / "report.json").read_text())
    params = [p for p in rep["parameters"]]
    assert len(params) == 42
    assert {f"leg{i}_{k}" for i in range(1, 7) for k in "abcmnql"} == {p["name"] for p in params}
    for p in params:
        assert p["std"] > 0 and abs(p["estimate"] - p["truth"]) <= p["tolerance"], p
    c = {ch["name"]: ch["value"] for ch in rep["checks"]}
    assert c["loop_closure_um"] <= 0.1
    assert c["station_error_um"] < 30
    assert c["pose_rms_after_um"] < c["pose_rms_before_um"] / 100
    assert c["pose_rms_after_um"] < c["pose_rms_after_two_step_um"]  # the one-step method wins
    cmp = rep["info"]["compare_rms_error_mm"]
    assert cmp["one_step"] < cmp["two_step"]
    paths = entity_paths(tmp_path / "run.rrd")
    expected = {
        "/world/platform",
        "/world/leg0/leg0_rod",
        "/tracker/stations",
        "/tracker/beams",
        "/two_step/leg1/sphere0",
        "/report",
        "/figures/stewart",
    }
    assert (tmp_path / "figure.png").stat().st_size > 20_000
    assert expected <= paths, expected - paths


def test_a_solve_that_runs_out_of_iterations_fails_the_run(tmp_path, monkeypatch):
    """Two Gauss-Newton iterations cannot converge from the drawing's hinges: the run must say
    so (a failed check, exit 1), not report the last iterate as an answer."""
    import calibench.scenarios.stewart.scenario as scenario
    from calibench.estimators.stewart import adjustment as est

    real = est.adjust_jointly
    monkeypatch.setattr(
        scenario, "adjust_jointly", lambda *a, **k: real(*a, **{**k, "iterations": 2})
    )
    assert main(["run", "stewart", "--no-rrd", "--out", str(tmp_path)]) == 1
    checks = {c["name"]: c for c in json.loads((tmp_path / "report.json").read_text())["checks"]}
    assert checks["solves_not_converged"]["value"] >= 1 and not checks["solves_not_converged"]["ok"]


def test_a_datasheet_off_by_a_common_factor_leaves_estimates_and_std_unchanged(tmp_path):
    """The estimators are told the datasheet's sigma, not the simulation's. Told 1.5x too much
    for both instruments (the tracker's lengths and the legs' readings), the joint adjustment
    weighs everything as before, finds a variance factor of 1 / 1.5^2 in its residuals and
    rescales its covariance by it: the same estimates and the same std as with the right
    datasheet (whose coverage the Monte-Carlo studies check), to the solver's convergence."""
    from calibench.scenarios.stewart.scenario import StewartConfig, run

    right = StewartConfig()
    off = dataclasses.replace(
        right,
        stated_length_sigma_um=tuple(1.5 * x for x in right.stated_length_sigma_um),
        stated_reading_sigma_um=1.5 * right.stated_reading_sigma_um,
    )
    a = run(right, 3, "analytic", tmp_path / "a", False)
    b = run(off, 3, "analytic", tmp_path / "b", False)
    pa, pb = {p.name: p for p in a.parameters}, {p.name: p for p in b.parameters}
    assert pa.keys() == pb.keys() and len(pa) == 42
    for k in pa:
        assert abs(pa[k].estimate - pb[k].estimate) < 1e-3 * pa[k].std, k
        assert pb[k].std == pytest.approx(pa[k].std, rel=1e-3), k
    assert b.info["whitened_rms"] == pytest.approx(a.info["whitened_rms"] / 1.5, rel=1e-3)


def test_the_two_step_caps_turn_about_a_basis_fixed_by_formula():
    """The cap's directions across the leg: orthonormal and right-handed about it, from a formula
    (an SVD's null space is LAPACK's free pick and moved the two-step's figures between CPUs)."""
    from calibench.scenarios.stewart.scenario import directions_across

    rng = np.random.default_rng(0)
    for u in [np.eye(3)[k] for k in range(3)] + list(rng.normal(size=(50, 3))):
        u = u / np.linalg.norm(u)
        a, b = directions_across(u)
        np.testing.assert_allclose(
            np.array([a, b, u]) @ np.array([a, b, u]).T, np.eye(3), atol=1e-15
        )
        np.testing.assert_allclose(np.cross(a, b), u, atol=1e-15)
