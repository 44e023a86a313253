"""The arm's calibration on measured points (estimators.arm.calibration, .coverage): recovery of a
twin's truth, the robust reweighting, the prior, a new frame's registration, the error figures.

Data come from the MuJoCo twin (sim): a UR10 whose shoulder and elbow give way under MuJoCo's
gravity, measured in two instrument frames with Gaussian noise; no kinematic errors, so every
kinematic parameter's truth is zero and every kept parameter has a truth to be judged against.
"""

import dataclasses

import numpy as np
import pytest

from calibench.estimators.arm.calibration import (
    PRIOR,
    DegenerateFit,
    calibrate,
    error_statistics,
    loaded_joints,
    register_frame,
)
from calibench.estimators.arm.kinematics import parameter_scales
from calibench.estimators.arm.workspace import coverage_warnings, span_deg, visited_bins
from calibench.estimators.rotations import matrix_to_rotvec, rotvec_to_matrix
from calibench.scenarios.arm_cmm.arms import chain_of
from calibench.sim.arm_cmm import ArmSim, ArmTruth

NOISE_MM = 0.02
STIFFNESS = (np.inf, 2.0e5, 1.5e5, np.inf, np.inf, np.inf)  # N m / rad: joints 2 and 3 give way
FRAMES = (
    (rotvec_to_matrix(np.array([0.01, -0.02, 2.2])), np.array([2100.0, 400.0, -250.0])),
    (rotvec_to_matrix(np.array([-0.03, 0.01, -0.8])), np.array([-900.0, 1800.0, 100.0])),
)


@pytest.fixture(scope="module")
def twin():
    """300 postures in each of two frames: (sim, chain, q (600, 6), xyz (600, 3), recording)."""
    sim = ArmSim("ur10", ArmTruth(delta=(0.0,) * 33, stiffness_nm_per_rad=STIFFNESS))
    rng = np.random.default_rng(0)
    q, y = [], []
    for R, t in FRAMES:
        qi = sim.random_postures(300, rng)
        q.append(qi)
        y.append(sim.probe_mm(qi) @ R.T + t + rng.normal(0, NOISE_MM, (300, 3)))
    return sim, chain_of(sim.arm), np.vstack(q), np.vstack(y), np.repeat([0, 1], 300)


@pytest.fixture(scope="module")
def fitted(twin):
    sim, chain, q, y, rec = twin
    return calibrate(chain, q, y, rec, None, "physics", sim.arm.parallel_pairs())


def _truth(problem) -> dict[str, float]:
    """Every parameter's true value: kinematics and tool zero, the compliances 1 / stiffness (rad
    / N m), each frame's turn from the problem's reference (rotvec) and its shift."""
    truth = {n: 0.0 for n in problem.names}
    for j in (2, 3):
        truth[f"compliance{j}"] = 1.0 / STIFFNESS[j - 1]
    for i, (R, t) in enumerate(FRAMES):
        v = np.r_[matrix_to_rotvec(R @ problem.R_ref[i].T), t]
        for k, f in enumerate(("rx", "ry", "rz", "x", "y", "z")):
            truth[f"base_{f}_{i + 1}"] = v[k]
    return truth


def test_calibrate_recovers_the_twins_truth_within_its_std(fitted):
    """Every kept parameter (kinematics, tool, the two loaded joints' compliance, both frames)
    within 4 of its std of the truth; the compliances to 3 % (their std is under 1 %); the joints
    gravity does not load are said, not estimated; the model-error sigma is the noise's."""
    cal = fitted
    truth = _truth(cal.problem)
    est, std = cal.ident.estimate, cal.ident.std
    assert {"compliance2", "compliance3"} <= set(est)
    assert "compliance1" in cal.compliance_dropped  # its axis is vertical: no gravity torque
    for name, value in est.items():
        assert abs(value - truth[name]) < 4 * std[name], (name, value, truth[name], std[name])
    for j in (2, 3):
        assert est[f"compliance{j}"] == pytest.approx(1.0 / STIFFNESS[j - 1], rel=0.03)
    # 1800 values: the sigma's relative std is 1 / sqrt(2 * 1800) = 1.7 %
    assert cal.sigma_model_mm == pytest.approx(NOISE_MM, rel=0.07)
    assert len(cal.outliers) == 0 and cal.ident.converged
    assert cal.ident.cov.shape == (len(est), len(est))
    np.testing.assert_allclose(np.sqrt(np.diag(cal.ident.cov)), list(std.values()), rtol=1e-12)


def test_rows_no_gaussian_scatter_explains_are_left_out_and_change_nothing(twin, fitted):
    """Five rows 1.5 mm off: the robust fit names exactly them and is then the fit of the rows
    without them; without the robust step they stay and widen the fitted scatter."""
    sim, chain, q, y, rec = twin
    bad = np.array([7, 150, 333, 420, 599])
    y_bad = y.copy()
    y_bad[bad] += np.array([1.5, -1.0, 0.5])
    cal = calibrate(chain, q, y_bad, rec, None, "physics", sim.arm.parallel_pairs())
    np.testing.assert_array_equal(cal.outliers, bad)
    keep = np.setdiff1d(np.arange(len(q)), bad)
    clean = calibrate(chain, q[keep], y[keep], rec[keep], None, "physics", sim.arm.parallel_pairs())
    for name, value in clean.ident.estimate.items():
        assert cal.ident.estimate[name] == pytest.approx(value, abs=1e-9 * clean.ident.std[name])
    naive = calibrate(chain, q, y_bad, rec, None, "physics", sim.arm.parallel_pairs(), robust=False)
    assert len(naive.outliers) == 0 and naive.sigma_model_mm > 2 * fitted.sigma_model_mm


def test_the_prior_bounds_what_the_data_cannot_pin_down(twin, fitted):
    """On postures where the upper arm stays within 20 deg of upright, some kinematic errors are
    barely determined: without the prior their std exceed the typical size, with it none exceeds
    its prior (PRIOR x the typical size). On the whole workspace the prior moves no estimate by
    more than 1 % of its std."""
    sim, chain, q, y, rec = twin
    narrow = np.abs(q[:, 1] + np.pi / 2) < 0.35
    ratio = {}
    for prior in (PRIOR, None):
        pairs = sim.arm.parallel_pairs()
        c = calibrate(
            chain, q[narrow], y[narrow], rec[narrow], None, "geometry", pairs, prior=prior
        )
        names = [n for n in c.ident.std if n.startswith(("da", "dd"))]
        ratio[prior] = np.array([c.ident.std[n] for n in names]) / parameter_scales(names)
    assert ratio[None].max() > 1.0 and ratio[PRIOR].max() <= PRIOR
    free = calibrate(chain, q, y, rec, None, "physics", sim.arm.parallel_pairs(), prior=None)
    assert set(free.ident.estimate) == set(fitted.ident.estimate)
    for name, value in fitted.ident.estimate.items():
        assert abs(free.ident.estimate[name] - value) < 0.01 * fitted.ident.std[name], name


def test_data_that_cannot_determine_the_fit_are_said():
    sim = ArmSim("ur10", ArmTruth(delta=(0.0,) * 33))
    chain, rng = chain_of(sim.arm), np.random.default_rng(3)
    q = sim.random_postures(12, rng)
    with pytest.raises(DegenerateFit, match="far too few"):
        calibrate(chain, q, sim.probe_mm(q), np.zeros(12, int), None, "geometry")
    q = np.repeat(q[:1], 100, axis=0)  # one posture: the tool point never moves
    y = sim.probe_mm(q) + rng.normal(0, NOISE_MM, (100, 3))
    with pytest.raises(DegenerateFit, match="singular"):
        calibrate(chain, q, y, np.zeros(100, int), None, "geometry")


def test_loaded_joints_are_those_gravity_turns(twin):
    """The UR10's first and last axes are vertical at rest (joint 1 always): no gravity torque,
    no compliance; shoulder and elbow carry the arm. An arm without masses has none."""
    sim, chain, q, _, _ = twin
    joints, why = loaded_joints(chain, q)
    assert {2, 3} <= set(joints) and 1 not in joints
    assert set(why) == {f"compliance{j}" for j in range(1, 7) if j not in joints}
    massless = chain_of(dataclasses.replace(sim.arm, mass_kg=None, com_mm=None))
    assert loaded_joints(massless, q) == ((), {})


def test_a_new_frame_is_registered_on_a_fifth_of_its_rows():
    """A known rigid transform of 300 points, 0.02 mm noise: registered on 20 % of the usable
    rows (the same rows for the same seed), judged on the rest; the frame's prediction of the
    noise-free points within 3 x its expected error, sigma sqrt(6 / k) for k rows."""
    rng = np.random.default_rng(1)
    base = rng.uniform(-500.0, 500.0, (300, 3))
    R, t = rotvec_to_matrix(np.array([0.2, -0.5, 1.1])), np.array([1500.0, -200.0, 300.0])
    xyz = base @ R.T + t + rng.normal(0, NOISE_MM, base.shape)
    usable = np.ones(300, bool)
    usable[[3, 30, 300 - 1]] = False
    f = register_frame(base, xyz, usable, 0.2, 0)
    assert len(f.register_rows) == round(0.2 * 297)
    both = np.r_[f.register_rows, f.judge_rows]
    np.testing.assert_array_equal(np.sort(both), np.flatnonzero(usable))
    assert np.all(np.diff(f.judge_rows) > 0)
    np.testing.assert_array_equal(
        register_frame(base, xyz, usable, 0.2, 0).register_rows, f.register_rows
    )
    assert set(register_frame(base, xyz, usable, 0.2, 1).register_rows) != set(f.register_rows)
    e = base @ f.R.T + f.t - base @ R.T - t
    rms = np.sqrt(np.mean(np.sum(e * e, axis=1)))
    assert rms < 3 * NOISE_MM * np.sqrt(6 / len(f.register_rows)), rms


def test_a_new_frame_that_cannot_be_registered_is_said():
    rng = np.random.default_rng(2)
    line = np.outer(np.linspace(0, 1000, 50), [1.0, 2.0, 0.5])
    with pytest.raises(DegenerateFit, match="one line"):
        register_frame(line, line + rng.normal(0, 1e-4, line.shape), np.ones(50, bool), 0.2, 0)
    pts = rng.uniform(0, 1000, (3, 3))
    with pytest.raises(DegenerateFit, match="rows to judge"):
        register_frame(pts, pts, np.ones(3, bool), 0.2, 0)


def test_error_statistics_of_known_lengths():
    """Errors of lengths 1 .. 100 mm in random directions: mean 50.5, RMS sqrt(3383.5), max 100,
    95th percentile 95.05 (linear between the 95th and 96th)."""
    rng = np.random.default_rng(4)
    u = rng.normal(size=(100, 3))
    e = u / np.linalg.norm(u, axis=1, keepdims=True) * np.arange(1, 101)[:, None]
    s = error_statistics(rng.permutation(e))
    assert s["samples"] == 100
    assert s["mean_mm"] == pytest.approx(50.5)
    assert s["rms_mm"] == pytest.approx(np.sqrt(3383.5))
    assert s["max_mm"] == pytest.approx(100.0) and s["p95_mm"] == pytest.approx(95.05)


def test_coverage_says_where_the_training_postures_never_went(twin):
    """Training with q2 near upright: q2's narrow span is said, and the test postures that put q2
    elsewhere; the full workspace raises nothing. Spans wrap at 360 deg."""
    sim, chain, q, _, _ = twin
    assert span_deg(np.array([350.0, 10.0, 0.0])) == pytest.approx(20.0)
    bins = visited_bins(np.array([[5.0, 355.0], [15.0, -5.0]]))
    assert bins.shape == (2, 36) and set(np.flatnonzero(bins[0])) == {0, 1}
    assert set(np.flatnonzero(bins[1])) == {35}
    narrow = np.abs(q[:, 1] + np.pi / 2) < 0.35
    warnings = coverage_warnings(chain, q[narrow], {"test.csv": q[~narrow]}, (2, 3))
    assert any(w.startswith("q2 spans only") for w in warnings), warnings
    assert any(w.startswith("test.csv:") and "q2" in w for w in warnings), warnings
    assert coverage_warnings(chain, q[:300], {"test.csv": q[300:]}, (2, 3)) == []
