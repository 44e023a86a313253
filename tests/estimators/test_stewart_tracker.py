"""The Stewart platform's measurement estimators on synthetic tracker lengths from a known truth
(no MuJoCo): the stations from the nests, the poses from the reflectors, the legs one by one, and
the legs' Jacobian's condition."""

import numpy as np
from scipy.spatial.transform import Rotation

from calibench.estimators.stewart.kinematics import leg_conditions, leg_lengths
from calibench.estimators.stewart.legs import calibrate_leg, calibrate_legs
from calibench.estimators.stewart.tracker import (
    locate_stations,
    multilaterate_many,
    poses_from_lengths,
)

NESTS = np.array([[700.0, -500.0, 0.0], [800.0, 500.0, 40.0], [-700.0, 700.0, 20.0]])
STATIONS = np.array([[1500.0, -500.0, 300.0], [1400.0, 600.0, 250.0], [-900.0, 1300.0, 350.0]])
REFLECTORS = np.array([[250.0, 0, 30], [-125, 216, 30], [-125, -216, 30]])


def _sigma(L):
    """A tracker's 1-sigma, 0.3 um + 0.3 um/m (mm)."""
    return (0.3 + 0.3 * L / 1000) / 1000


def _hexapod():
    a, b = np.deg2rad([-15, 15, 105, 135, 225, 255]), np.deg2rad([-45, 45, 75, 165, 195, 285])
    B = np.c_[500 * np.cos(a), 500 * np.sin(a), np.zeros(6)]
    r = np.c_[300 * np.cos(b), 300 * np.sin(b), np.zeros(6)]
    return r, B


def _poses(rng, n):
    R = Rotation.from_rotvec(rng.uniform(-0.17, 0.17, (n, 3))).as_matrix()
    return R, np.array([0, 0, 750.0]) + rng.uniform(-150, 150, (n, 3))


def test_stations_from_the_nests_are_within_their_covariance():
    """Noise-free lengths give the stations exactly; over 300 noisy draws each station's error,
    in units of the covariance returned with it (Mahalanobis), is chi-square with 3 dof: its mean
    3 within 10 % (3 std of the mean of 300 is 0.5) and none beyond 27 (1e-5 tail)."""
    rng = np.random.default_rng(40)
    L = np.linalg.norm(NESTS[None] - STATIONS[:, None], axis=2)  # (station, nest)
    exact, _ = locate_stations(NESTS, L, _sigma(L), above=[0, 0, 1.0])
    np.testing.assert_allclose(exact, STATIONS, atol=1e-8)
    d2 = []
    for _ in range(300):
        found, cov = locate_stations(NESTS, L + rng.normal(0, _sigma(L)), _sigma(L), [0, 0, 1.0])
        err = found - STATIONS
        d2 += [e @ np.linalg.solve(c, e) for e, c in zip(err, cov)]
    assert abs(np.mean(d2) - 3) < 0.3 and max(d2) < 27


def test_poses_from_the_reflectors_lengths_recover_the_poses():
    """Noise-free lengths give every pose (1e-9); noisy ones put the reflectors where the
    multilaterated points' own covariance says, a little closer (the rigid fit of three points
    averages 9 coordinates into 6 degrees of freedom: sqrt(6/9) = 0.82 of the points' scatter)."""
    rng = np.random.default_rng(41)
    R, t = _poses(rng, 200)
    P = np.einsum("nij,kj->nki", R, REFLECTORS) + t[:, None]  # (n, 3 reflectors, 3)
    L = np.linalg.norm(P[:, :, None] - STATIONS[None, None], axis=3)  # (n, reflector, station)
    R_guess = Rotation.from_rotvec(rng.normal(0, 0.01, (200, 3))).as_matrix() @ R
    Rf, tf, ok = poses_from_lengths(REFLECTORS, STATIONS, L, _sigma(L), R_guess, t + 2.0)
    assert ok.all()
    np.testing.assert_allclose(Rf, R, atol=1e-9)
    np.testing.assert_allclose(tf, t, atol=1e-7)
    noisy = L + rng.normal(0, _sigma(L))
    Rf, tf, ok = poses_from_lengths(REFLECTORS, STATIONS, noisy, _sigma(L), R_guess, t + 2.0)
    assert ok.all()
    err = np.einsum("nij,kj->nki", Rf, REFLECTORS) + tf[:, None] - P
    _, cov, _ = multilaterate_many(
        STATIONS, noisy.reshape(-1, 3), _sigma(L).reshape(-1, 3), P.reshape(-1, 3)
    )
    ratio = np.sqrt(np.mean(np.sum(err**2, axis=2)) / np.mean(np.trace(cov, axis1=1, axis2=2)))
    assert 0.65 < ratio < 1.05, ratio


def test_six_legs_calibrated_at_once_are_each_leg_alone_and_recover_the_truth():
    """The one-step method over the six legs: each leg's result is calibrate_leg's on its own
    column, and every parameter within 5 of its std of the truth (readings with 2 um noise)."""
    rng = np.random.default_rng(42)
    r, B = _hexapod()
    r, B = r + rng.normal(0, 0.4, (6, 3)), B + rng.normal(0, 0.4, (6, 3))
    l = 650.0 + rng.normal(0, 0.5, 6)
    R, t = _poses(rng, 60)
    sigma = np.full(60, 0.002)
    readings = np.array([leg_lengths(Ri, ti, r, B) for Ri, ti in zip(R, t)]) - l
    readings += rng.normal(0, 0.002, readings.shape)
    r0, B0 = _hexapod()
    legs = calibrate_legs(R, t, readings, r0, B0, np.full(6, 650.0), sigma)
    for i, cal in enumerate(legs):
        alone = calibrate_leg(R, t, readings[:, i], r0[i], B0[i], 650.0, sigma)
        np.testing.assert_array_equal(np.r_[cal.r, cal.B, cal.l], np.r_[alone.r, alone.B, alone.l])
        assert cal.converged
        assert np.all(np.abs(np.r_[cal.r, cal.B, cal.l] - np.r_[r[i], B[i], l[i]]) < 5 * cal.std)


def test_leg_conditions_are_the_lengths_and_the_jacobians_condition():
    """At home the lengths are the hinges' distances and the condition the one of the Jacobian
    written out row by row; hinges all at the platform's centre leave it singular (turns about
    the centre move no leg)."""
    r, B = _hexapod()
    home = np.array([[0.0, 0.0, 750.0]])
    L, cond = leg_conditions(r, B, np.eye(3)[None], home)
    np.testing.assert_allclose(L[0], np.linalg.norm(r + home - B, axis=1))
    u = (r + home - B) / L[0][:, None]
    J = np.c_[u, np.cross(r, u) / 300.0]
    assert cond[0] == np.linalg.cond(J) or abs(cond[0] / np.linalg.cond(J) - 1) < 1e-12
    assert 1 < cond[0] < 100
    centre = np.zeros((6, 3)) + [1e-9, 0, 0]
    _, cond = leg_conditions(centre, B, np.eye(3)[None], home)
    assert cond[0] > 1e6
