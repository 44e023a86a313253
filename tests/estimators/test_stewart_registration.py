"""Discovery's registration of a Stewart platform: the tracker's frame, and the legs with it, from
poses the tracker measured (:mod:`calibench.estimators.stewart.registration`), on synthetic
readings of a known truth. A rigid leg's length is geometry (tests/estimators/test_stewart.py's
docstring says why no MuJoCo here); the twin's readings meet it in the Stewart discovery tests."""

import numpy as np

from calibench.estimators.rotations import rotvec_to_matrix
from calibench.estimators.stewart.registration import (
    RegistrationProblem,
    RegistrationState,
    register_frame,
    register_with_legs,
)
from tests.estimators.synthetic import hexapod, rotation

SIGMA_MM = 1e-3  # the legs' reading noise


def _recording(rng, n=80):
    """A truth (frame, legs) and the readings (n, 6) of n poses the tracker measured exactly."""
    r, B = hexapod()
    r, B = r + rng.normal(0, 0.4, (6, 3)), B + rng.normal(0, 0.4, (6, 3))
    l = np.full(6, 650.0) + rng.normal(0, 0.5, 6)
    Rf, tf = rotation(np.array([0.02, -0.01, 0.8])), np.array([1200.0, -300.0, 150.0])
    R = np.array([rotation(rng.uniform(-0.17, 0.17, 3)) for _ in range(n)])  # base frame
    t = np.array([0, 0, 750.0]) + rng.uniform(-150, 150, (n, 3))
    legs = np.linalg.norm(np.einsum("nij,lj->nli", R, r) + t[:, None] - B, axis=2)
    readings = legs - l + rng.normal(0, SIGMA_MM, legs.shape)
    R_tracker = np.einsum("ji,njk->nik", Rf, R)  # Rf^T R: what the tracker reports
    t_tracker = (t - tf) @ Rf
    return readings, R_tracker, t_tracker, RegistrationState(Rf, tf, r, B, l)


def _off(truth: RegistrationState, rng, legs_mm: float = 0.0) -> RegistrationState:
    """A start 2 mrad and 2 mm off in the frame, ``legs_mm`` in every leg parameter."""
    turn = rotvec_to_matrix(rng.normal(0, 2e-3, 3))
    d = rng.normal(0, legs_mm, (6, 7)) if legs_mm else np.zeros((6, 7))
    return RegistrationState(
        turn @ truth.Rf,
        truth.tf + rng.normal(0, 2.0, 3),
        truth.r + d[:, :3],
        truth.B + d[:, 3:6],
        truth.l + d[:, 6],
    )


def test_registration_jacobian_matches_finite_differences():
    """Every column against central differences of the residuals through the problem's update
    (the frame turned on the left)."""
    rng = np.random.default_rng(40)
    readings, R, t, truth = _recording(rng, n=5)
    problem = RegistrationProblem(readings, R, t, _off(truth, rng, 0.3), SIGMA_MM)
    s0 = problem.start()
    J = problem.jacobian(s0)
    assert J.shape == (30, 48) == (len(problem.residuals(s0)), len(problem.names))
    h = 1e-6

    def f(x):
        return problem.residuals(problem.update(s0, x))

    Jn = np.array([(f(h * e) - f(-h * e)) / (2 * h) for e in np.eye(48)]).T
    np.testing.assert_allclose(J, Jn, atol=1e-6 * np.abs(J).max())


def test_the_frame_is_recovered_within_its_std_on_the_true_legs():
    """From 2 mrad and 2 mm off: the frame within 5 of its reported std, which (80 poses of six
    1 um readings over a metre's lever) is under a micrometre and a microradian; the whitened
    residual RMS 1 within 3 sigma of 480 samples (10 %)."""
    rng = np.random.default_rng(41)
    readings, R, t, truth = _recording(rng)
    problem = RegistrationProblem(readings, R, t, _off(truth, rng), SIGMA_MM)
    ident = register_frame(problem)
    assert ident.converged, ident.status
    est, std = problem.values(ident.state)[:6], np.array(list(ident.std.values()))
    true = problem.values(truth)[:6]
    assert np.all(np.abs(est - true) < 5 * std), (est - true) / std
    assert np.all(std[:3] < 1e-6) and np.all(std[3:] < 1e-3), std
    assert abs(ident.rms - 1) < 0.1, ident.rms


def test_frame_and_legs_leave_only_the_noise_and_drop_what_the_frame_repeats():
    """From 0.3 mm off in every leg parameter: what is left is the noise (RMS within 10 % of 1
    whitened, over the kept columns' degrees of freedom), and the basis drops six columns: the base
    hinges turned and shifted together move the data as the frame does."""
    rng = np.random.default_rng(42)
    readings, R, t, truth = _recording(rng)
    problem = RegistrationProblem(readings, R, t, _off(truth, rng, 0.3), SIGMA_MM)
    ident = register_with_legs(problem)
    assert ident.converged, ident.status
    assert len(ident.basis.dropped) == 6, ident.basis.dropped
    left = problem.residuals(ident.state)
    dof = len(left) - len(ident.basis.kept)
    assert abs(np.sqrt(left @ left / dof) - 1) < 0.1
    # the whole problem's readings reproduced: the truth's own residual is no smaller
    assert left @ left <= problem.residuals(truth) @ problem.residuals(truth) + 1e-9
