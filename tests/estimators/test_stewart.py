"""Stewart-platform estimators on synthetic data from a known truth (no MuJoCo)."""

import numpy as np
import pytest

from estimators.stewart import (calibrate_leg, fit_sphere, forward_kinematics, leg_lengths, multilaterate,
                                rigid_transform, trilaterate)

NESTS = np.array([[700.0, -500.0, 0.0], [800.0, 500.0, 700.0], [-700.0, 700.0, 1300.0]])
STATION = np.array([1500.0, -500.0, 300.0])


def _rot(w):
    th = np.linalg.norm(w)
    k = w / th
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(th) * K + (1 - np.cos(th)) * K @ K


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
    sols = np.array([trilaterate(NESTS, d + rng.normal(0, sigma), sigma, above=np.array([1.0, 0, 0]))[0]
                     for _ in range(4000)])
    np.testing.assert_allclose(np.std(sols, axis=0) / np.sqrt(np.diag(cov)), 1.0, atol=0.2)
    np.testing.assert_allclose(np.cov(sols.T), cov, atol=0.25 * np.max(np.abs(cov)))


def test_multilateration_and_rigid_transform_recover_a_pose():
    stations = np.array([[1500.0, -500.0, 300.0], [1600.0, 500.0, 900.0], [1400.0, -100.0, 1500.0]])
    refl = np.array([[173.2, 100.0, 40.0], [-173.2, 100.0, 40.0], [0.0, -200.0, 40.0]])
    R, t = _rot(np.array([0.05, -0.08, 0.3])), np.array([20.0, -35.0, 760.0])
    world = refl @ R.T + t
    found = np.array([multilaterate(stations, np.linalg.norm(stations - w, axis=1), np.full(3, 1e-3),
                                    w + 5.0)[0] for w in world])
    Rf, tf = rigid_transform(refl, found)
    np.testing.assert_allclose(Rf, R, atol=1e-9)
    np.testing.assert_allclose(tf, t, atol=1e-7)


def test_sphere_through_points():
    rng = np.random.default_rng(21)
    c, r = np.array([10.0, -20.0, 700.0]), 650.0
    u = rng.normal(size=(9, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    fc, fr = fit_sphere(c + r * u)
    np.testing.assert_allclose(fc, c, atol=1e-8)
    assert fr == pytest.approx(r, abs=1e-8)
    with pytest.raises(ValueError, match="coplanar"):
        fit_sphere(np.c_[rng.normal(size=(6, 2)), np.zeros(6)])


def test_one_step_recovers_a_leg_within_its_std():
    rng = np.random.default_rng(22)
    r, B, l = np.array([212.0, 212.3, 0.4]), np.array([483.0, -129.0, -0.3]), 650.4
    z = []
    for trial in range(40):
        Rs = np.array([_rot(rng.uniform(-0.17, 0.17, 3) + 1e-9) for _ in range(60)])
        ts = np.array([0, 0, 750.0]) + rng.uniform(-150, 150, (60, 3))
        L = np.linalg.norm(np.einsum("nij,j->ni", Rs, r) + ts - B, axis=1)
        sigma = 0.002
        readings = L - l + rng.normal(0, sigma, 60)
        cal = calibrate_leg(Rs, ts, readings, r + 0.5, B - 0.5, 650.0, np.full(60, sigma))
        z.append((np.r_[cal.r, cal.B, cal.l] - np.r_[r, B, l]) / cal.std)
    z = np.array(z)
    assert np.all(np.abs(z) < 5)
    assert 0.7 < np.sqrt(np.mean(z**2)) < 1.3


def test_forward_kinematics_inverts_the_leg_lengths():
    a = np.deg2rad([-15, 15, 105, 135, 225, 255])
    B = np.c_[500 * np.cos(a), 500 * np.sin(a), np.zeros(6)]
    b = np.deg2rad([-45, 45, 75, 165, 195, 285])
    r = np.c_[300 * np.cos(b), 300 * np.sin(b), np.zeros(6)]
    R, t = _rot(np.array([0.1, -0.05, 0.12])), np.array([40.0, -60.0, 820.0])
    Rf, tf = forward_kinematics(leg_lengths(R, t, r, B), r, B, np.eye(3), np.array([0, 0, 750.0]))
    np.testing.assert_allclose(Rf, R, atol=1e-10)
    np.testing.assert_allclose(tf, t, atol=1e-8)
