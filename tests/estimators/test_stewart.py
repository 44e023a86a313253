"""Stewart-platform estimators on synthetic data from a known truth, without MuJoCo.

A rigid leg's length is geometry, |R r + t - B|, not a physics model: the twin
(sim/stewart.py) poses its legs by the same distance and MuJoCo checks that each leg's end
meets its platform hinge (the loop closure, under 0.1 um in `run stewart`). What the twin adds,
the legs' physics under MuJoCo's statics, is tested in tests/sim and tests/scenarios; these
estimators meet the twin's readings in tests/scenarios/test_stewart.py. Here their statistics
are checked over thousands of draws, which the twin would only make slower."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from calibench.estimators.rotations import rigid_transform, rotvec_to_matrix
from calibench.estimators.stewart.adjustment import (
    JointProblem,
    TrackerObservations,
    adjust_jointly,
    joint_information,
)
from calibench.estimators.stewart.kinematics import (
    forward_kinematics,
    forward_kinematics_many,
    leg_lengths,
)
from calibench.estimators.stewart.legs import calibrate_leg, fit_sphere
from calibench.estimators.stewart.tracker import multilaterate, multilaterate_many, trilaterate
from tests.estimators.synthetic import hexapod, rotation

NESTS = np.array([[700.0, -500.0, 0.0], [800.0, 500.0, 700.0], [-700.0, 700.0, 1300.0]])
STATION = np.array([1500.0, -500.0, 300.0])


def test_trilateration_is_exact_and_picks_the_side():
    d = np.linalg.norm(NESTS - STATION, axis=1)
    p, _ = trilaterate(NESTS, d, np.full(3, 1e-3), above=np.array([1.0, 0, 0]))
    mirror, _ = trilaterate(NESTS, d, np.full(3, 1e-3), above=np.array([-1.0, 0, 0]))
    np.testing.assert_allclose(p, STATION, atol=1e-8)
    assert np.linalg.norm(mirror - STATION) > 100


def test_station_uncertainty_propagation_matches_monte_carlo():
    """The seed's Eq. 4-5 (Jacobian propagation) against the spread of 4000 noisy solutions:
    within 20 % on every axis."""
    rng = np.random.default_rng(20)
    d = np.linalg.norm(NESTS - STATION, axis=1)
    sigma = (0.3 + 0.3 * d / 1000) / 1000
    _, cov = trilaterate(NESTS, d, sigma, above=np.array([1.0, 0, 0]))
    sols = np.array(
        [
            trilaterate(NESTS, d + rng.normal(0, sigma), sigma, above=np.array([1.0, 0, 0]))[0]
            for _ in range(4000)
        ]
    )
    np.testing.assert_allclose(np.std(sols, axis=0) / np.sqrt(np.diag(cov)), 1.0, atol=0.2)
    np.testing.assert_allclose(np.cov(sols.T), cov, atol=0.25 * np.max(np.abs(cov)))


def test_multilateration_and_rigid_transform_recover_a_pose():
    stations = np.array([[1500.0, -500.0, 300.0], [1600.0, 500.0, 900.0], [1400.0, -100.0, 1500.0]])
    refl = np.array([[173.2, 100.0, 40.0], [-173.2, 100.0, 40.0], [0.0, -200.0, 40.0]])
    R, t = rotation(np.array([0.05, -0.08, 0.3])), np.array([20.0, -35.0, 760.0])
    world = refl @ R.T + t
    sols = [
        multilaterate(stations, np.linalg.norm(stations - w, axis=1), np.full(3, 1e-3), w + 5.0)
        for w in world
    ]
    assert all(ok for _, _, ok in sols)
    found = np.array([p for p, _, _ in sols])
    Rf, tf = rigid_transform(refl, found)
    np.testing.assert_allclose(Rf, R, atol=1e-9)
    np.testing.assert_allclose(tf, t, atol=1e-7)


def test_sphere_through_points():
    rng = np.random.default_rng(21)
    c, r = np.array([10.0, -20.0, 700.0]), 650.0
    u = rng.normal(size=(9, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    fc, fr, ok = fit_sphere(c + r * u)
    assert ok
    np.testing.assert_allclose(fc, c, atol=1e-8)
    assert fr == pytest.approx(r, abs=1e-8)
    with pytest.raises(ValueError, match="coplanar"):
        fit_sphere(np.c_[rng.normal(size=(6, 2)), np.zeros(6)])


def test_one_step_recovers_a_leg_within_its_std():
    rng = np.random.default_rng(22)
    r, B, l = np.array([212.0, 212.3, 0.4]), np.array([483.0, -129.0, -0.3]), 650.4
    z = []
    for _ in range(40):
        Rs = np.array([rotation(rng.uniform(-0.17, 0.17, 3) + 1e-9) for _ in range(60)])
        ts = np.array([0, 0, 750.0]) + rng.uniform(-150, 150, (60, 3))
        L = np.linalg.norm(np.einsum("nij,j->ni", Rs, r) + ts - B, axis=1)
        sigma = 0.002
        readings = L - l + rng.normal(0, sigma, 60)
        cal = calibrate_leg(Rs, ts, readings, r + 0.5, B - 0.5, 650.0, np.full(60, sigma))
        z.append((np.r_[cal.r, cal.B, cal.l] - np.r_[r, B, l]) / cal.std)
    z = np.array(z)
    assert np.all(np.abs(z) < 5)
    assert 0.7 < np.sqrt(np.mean(z**2)) < 1.3


def test_one_step_std_is_honest_per_parameter():
    """Each of the leg's seven parameters on its own, over 1000 noisy calibrations (truth: legs
    from the closed-form length |R r + t - B| at random poses, rotations from scipy): the RMS of
    (estimate - truth) / std is 1 when the std is honest (Student's t with 53 dof: 1.02), with a
    spread of about 0.025 at 1000 trials, so 0.85-1.2 is over 5 sigma either side. A pooled RMS
    (the test above) cannot see one parameter's std 1.3 x off (1 / 1.3 = 0.77 on one of seven
    moves it by 3 %); here it falls outside the band."""
    rng = np.random.default_rng(23)
    r, B, l = np.array([212.0, 212.3, 0.4]), np.array([483.0, -129.0, -0.3]), 650.4
    sigma, n = 0.002, 60
    z = []
    for _ in range(1000):
        Rs = Rotation.from_rotvec(rng.uniform(-0.17, 0.17, (n, 3))).as_matrix()
        ts = np.array([0, 0, 750.0]) + rng.uniform(-150, 150, (n, 3))
        L = np.linalg.norm(np.einsum("nij,j->ni", Rs, r) + ts - B, axis=1)
        readings = L - l + rng.normal(0, sigma, n)
        cal = calibrate_leg(Rs, ts, readings, r + 0.5, B - 0.5, 650.0, np.full(n, sigma))
        z.append((np.r_[cal.r, cal.B, cal.l] - np.r_[r, B, l]) / cal.std)
    rms = np.sqrt(np.mean(np.square(z), axis=0))
    assert np.all((rms > 0.85) & (rms < 1.2)), ", ".join(
        f"{k} {v:.3f}" for k, v in zip("abcmnql", rms)
    )


def test_forward_kinematics_inverts_the_leg_lengths():
    a = np.deg2rad([-15, 15, 105, 135, 225, 255])
    B = np.c_[500 * np.cos(a), 500 * np.sin(a), np.zeros(6)]
    b = np.deg2rad([-45, 45, 75, 165, 195, 285])
    r = np.c_[300 * np.cos(b), 300 * np.sin(b), np.zeros(6)]
    R, t = rotation(np.array([0.1, -0.05, 0.12])), np.array([40.0, -60.0, 820.0])
    Rf, tf, ok = forward_kinematics(
        leg_lengths(R, t, r, B), r, B, np.eye(3), np.array([0, 0, 750.0])
    )
    assert ok
    np.testing.assert_allclose(Rf, R, atol=1e-10)
    np.testing.assert_allclose(tf, t, atol=1e-8)


def _joint_problem(rng, n=40, sigma=(0.3e-3, 0.3e-6), reading_sigma=1e-3):
    """A truth (stations, poses, legs) and what the tracker and the legs would read of it."""
    r, B = hexapod()
    r, B = r + rng.normal(0, 0.4, (6, 3)), B + rng.normal(0, 0.4, (6, 3))
    l = np.full(6, 650.0) + rng.normal(0, 0.5, 6)
    stations = np.array([[1500.0, -500.0, 300.0], [1400.0, 600.0, 250.0], [-900.0, 1300.0, 350.0]])
    refl = np.array([[250.0, 0, 30], [-125, 216, 30], [-125, -216, 30]])
    R = np.array([rotation(rng.uniform(-0.17, 0.17, 3)) for _ in range(n)])
    t = np.array([0, 0, 750.0]) + rng.uniform(-150, 150, (n, 3))

    def noisy(L):
        return L + rng.normal(0, sigma[0] + sigma[1] * L)

    nest_L = noisy(np.linalg.norm(NESTS[None] - stations[:, None], axis=2))
    P = np.einsum("nij,kj->nki", R, refl) + t[:, None]
    refl_L = noisy(np.linalg.norm(P[:, :, None] - stations[None, None], axis=3))
    legs = np.linalg.norm(np.einsum("nij,lj->nli", R, r) + t[:, None] - B, axis=2)
    readings = legs - l + rng.normal(0, reading_sigma, legs.shape)
    obs = TrackerObservations(NESTS, nest_L, refl, refl_L, readings, sigma, reading_sigma)
    return obs, (stations, R, t, r, B, l)


def test_joint_jacobian_matches_finite_differences():
    """The joint problem's sparse Jacobian against central differences of its residuals through
    its own update (left rotation increments), every column."""
    rng = np.random.default_rng(30)
    obs, (S, R, t, r, B, l) = _joint_problem(rng, n=4)
    problem = JointProblem(obs, S, R, t, r, B, l)
    s0 = problem.start()
    J = problem.jacobian(s0).toarray()
    assert (
        J.shape == (9 + 4 * 15, 9 + 4 * 6 + 42) == (len(problem.residuals(s0)), len(problem.names))
    )
    h = 1e-6

    def f(x):
        return problem.residuals(problem.update(s0, x))

    Jn = np.array([(f(h * e) - f(-h * e)) / (2 * h) for e in np.eye(J.shape[1])]).T
    np.testing.assert_allclose(J, Jn, atol=1e-6 * np.abs(J).max())


def test_joint_information_is_the_legs_block_of_the_dense_inverse():
    """The legs' block of the full (J^T J)^-1, with stations and poses as nuisance parameters,
    against the dense inverse of the dense Jacobian (itself checked against finite differences
    above)."""
    rng = np.random.default_rng(32)
    obs, (S, R, t, r, B, l) = _joint_problem(rng, n=12)
    problem = JointProblem(obs, S, R, t, r, B, l)
    J = problem.jacobian(problem.start()).toarray()
    dense = np.linalg.inv(J.T @ J)[-42:, -42:]
    np.testing.assert_allclose(
        joint_information(obs, S, R, t, r, B, l), dense, rtol=1e-7, atol=1e-9 * np.abs(dense).max()
    )


def test_joint_adjustment_recovers_the_legs_and_its_std_is_the_bound():
    """From a start 0.3 mm off everywhere, 15 noisy calibrations: every leg parameter within 5 of
    its std, the normalised errors' RMS within 15 % of 1 (630 samples: 3 sigma is 8 %), and the
    reported std, less the variance factor, equal to the CRLB at the truth within 2 % (the problem
    is nearly linear)."""
    rng = np.random.default_rng(31)
    z = []
    for _ in range(15):
        obs, (S, R, t, r, B, l) = _joint_problem(rng)
        n = len(R)
        R0 = np.array([rotvec_to_matrix(w) @ Ri for w, Ri in zip(rng.normal(0, 1e-4, (n, 3)), R)])
        cal = adjust_jointly(obs, S + 0.3, R0, t + 0.3, r + 0.3, B - 0.3, l + 0.3)
        est = np.c_[cal.r, cal.B, cal.l].ravel()
        z.append((est - np.c_[r, B, l].ravel()) / cal.std)
        bound = np.sqrt(np.diag(joint_information(obs, S, R, t, r, B, l)))
        # the std carry the residuals' variance factor (cal.rms^2); without it they are the bound
        np.testing.assert_allclose(cal.std / cal.rms, bound, rtol=0.02)
        assert 0.7 < cal.rms < 1.3
    z = np.array(z)
    assert np.all(np.abs(z) < 5)
    assert 0.85 < np.sqrt(np.mean(z**2)) < 1.15


def test_a_joint_adjustment_cut_short_is_not_converged():
    """Two iterations from a start 0.3 mm off cannot reach the minimum: the calibration says so
    (the solver's status), and the full solve from the same start does converge."""
    rng = np.random.default_rng(33)
    obs, (S, R, t, r, B, l) = _joint_problem(rng, n=20)
    start = (S + 0.3, R, t + 0.3, r + 0.3, B - 0.3, l + 0.3)
    assert not adjust_jointly(obs, *start, iterations=2).converged
    full = adjust_jointly(obs, *start)
    assert full.converged
    assert np.all(
        np.abs(np.c_[full.r, full.B, full.l].ravel() - np.c_[r, B, l].ravel()) < 5 * full.std
    )


def test_newton_loops_cut_short_say_they_did_not_converge():
    """One iteration from a start 50 mm (or 0.1 rad) off cannot converge: each solver says so
    instead of handing back its last iterate as an answer."""
    stations = np.array([[1500.0, -500.0, 300.0], [1600.0, 500.0, 900.0], [1400.0, -100.0, 1500.0]])
    w = np.array([20.0, -35.0, 760.0])
    assert not multilaterate(
        stations, np.linalg.norm(stations - w, axis=1), np.full(3, 1e-3), w + 50.0, iterations=1
    )[2]
    a, b = np.deg2rad([-15, 15, 105, 135, 225, 255]), np.deg2rad([-45, 45, 75, 165, 195, 285])
    B = np.c_[500 * np.cos(a), 500 * np.sin(a), np.zeros(6)]
    r = np.c_[300 * np.cos(b), 300 * np.sin(b), np.zeros(6)]
    R, t = rotation(np.array([0.1, -0.05, 0.12])), np.array([40.0, -60.0, 820.0])
    assert not forward_kinematics(
        leg_lengths(R, t, r, B), r, B, np.eye(3), np.array([0, 0, 750.0]), iterations=1
    )[2]


def test_many_points_multilaterated_at_once_are_each_one_alone():
    """The batched multilateration against the single-point one, point by point: the same
    points (1e-9 mm), covariances and convergence flags."""
    rng = np.random.default_rng(8)
    stations = np.array([[1500.0, -500.0, 300.0], [1600.0, 500.0, 900.0], [1400.0, -100.0, 1500.0]])
    pts = rng.normal(0, 200, (5, 3)) + [0, 0, 760]
    d = np.linalg.norm(pts[:, None] - stations[None], axis=2) + rng.normal(0, 1e-3, (5, 3))
    sig = np.full((5, 3), 1e-3)
    p, cov, ok = multilaterate_many(stations, d, sig, pts + 5.0)
    for i in range(5):
        q, c, one_ok = multilaterate(stations, d[i], sig[i], pts[i] + 5.0)
        np.testing.assert_allclose(p[i], q, atol=1e-9)
        np.testing.assert_allclose(cov[i], c, rtol=1e-6)
        assert ok[i] == one_ok


def _platform_and_poses(n: int):
    """A platform's hinges r (6, 3), its base's B (6, 3) and ``n`` random poses about 800 mm up,
    with their legs' lengths (n, 6)."""
    rng = np.random.default_rng(9)
    a, b = np.deg2rad([-15, 15, 105, 135, 225, 255]), np.deg2rad([-45, 45, 75, 165, 195, 285])
    B = np.c_[500 * np.cos(a), 500 * np.sin(a), np.zeros(6)]
    r = np.c_[300 * np.cos(b), 300 * np.sin(b), np.zeros(6)]
    poses = [
        (rotation(rng.normal(0, 0.08, 3)), np.array([0, 0, 800.0]) + rng.normal(0, 50, 3))
        for _ in range(n)
    ]
    return r, B, poses, np.array([leg_lengths(R, t, r, B) for R, t in poses])


def test_many_poses_from_leg_lengths_at_once_are_each_one_alone():
    """Batched forward kinematics against the single-pose Newton, pose by pose (1e-9)."""
    r, B, poses, L = _platform_and_poses(6)
    Rm, tm, ok = forward_kinematics_many(L, r, B, np.eye(3), np.array([0, 0, 750.0]))
    assert ok.all()
    for i in range(len(poses)):
        R1, t1, _ = forward_kinematics(L[i], r, B, np.eye(3), np.array([0, 0, 750.0]))
        np.testing.assert_allclose(Rm[i], R1, atol=1e-9)
        np.testing.assert_allclose(tm[i], t1, atol=1e-9)


def test_a_leg_set_no_pose_can_take_fails_alone():
    """One set with a leg of -500 mm (no pose has it: the Newton leaves the finite numbers) among
    good ones: that set is not converged, every other is solved as if alone."""
    r, B, poses, L = _platform_and_poses(5)
    bad = L.copy()
    bad[2, 3] = -500.0
    with np.errstate(all="raise"):  # no warning may leak either
        Rm, tm, ok = forward_kinematics_many(bad, r, B, np.eye(3), np.array([0, 0, 750.0]))
    assert not ok[2] and ok[[0, 1, 3, 4]].all()
    for i in (0, 1, 3, 4):
        np.testing.assert_allclose(tm[i], poses[i][1], atol=1e-9)
