"""The two-step method (a leg locked, the platform origin on a sphere about B - R r at three
orientations) on synthetic tracker lengths from a known leg (no MuJoCo)."""

import numpy as np
from scipy.spatial.transform import Rotation

from calibench.estimators.stewart.legs import two_step_leg

STATIONS = np.array([[1500.0, -500.0, 300.0], [1400.0, 600.0, 250.0], [-900.0, 1300.0, 350.0]])
REFLECTORS = np.array([[250.0, 0, 30], [-125, 216, 30], [-125, -216, 30]])
R_LEG, B_LEG, L0 = np.array([212.0, 212.3, 0.4]), np.array([483.0, -129.0, -0.3]), 650.4
SIGMA = 1e-3  # mm, the tracker's lengths


def _experiment(rng, sigma):
    """The locked leg's reading, and for three orientations (0, 10 degrees about x, about y) nine
    places of the platform origin on the sphere of the leg's length about B - R r (the truth):
    the commanded orientations (3, 3, 3) and places (3, 9, 3), the tracker's lengths (3, 9, 3, 3)
    with noise ``sigma``."""
    orientations = Rotation.from_rotvec(np.deg2rad([[0, 0, 0], [10, 0, 0], [0, 10, 0]])).as_matrix()
    length = np.linalg.norm(R_LEG + [0, 0, 750.0] - B_LEG)  # the leg at home
    places, lengths = [], []
    for R in orientations:
        centre = B_LEG - R @ R_LEG
        u = ([0, 0, 750.0] - centre) / np.linalg.norm([0, 0, 750.0] - centre)
        tilt = Rotation.from_rotvec(rng.normal(0, 0.15, (9, 3))).as_matrix()
        t = centre + length * (tilt @ u)
        P = (REFLECTORS @ R.T)[None] + t[:, None]  # (9, 3 reflectors, 3)
        L = np.linalg.norm(P[:, :, None] - STATIONS[None, None], axis=3)
        places.append(t)
        lengths.append(L + rng.normal(0, sigma, L.shape))
    return length - L0, orientations, np.array(places), np.array(lengths)


def test_noise_free_lengths_give_the_leg_exactly():
    rng = np.random.default_rng(50)
    locked, R, places, lengths = _experiment(rng, 0.0)
    leg = two_step_leg(
        REFLECTORS, STATIONS, lengths, np.full(lengths.shape, SIGMA), R, places + 1.0, locked
    )
    assert leg.unconverged == 0
    np.testing.assert_allclose(np.r_[leg.r, leg.B, leg.l], np.r_[R_LEG, B_LEG, L0], atol=1e-6)
    assert leg.centres.shape == (3, 3) and leg.origins.shape == (3, 9, 3)
    np.testing.assert_allclose(leg.radii, locked + L0, atol=1e-7)


def test_noisy_lengths_give_the_leg_without_bias_and_in_proportion_to_the_noise():
    """Over 40 experiments with 1 um of noise the errors average to zero (within 4 standard
    errors of their own scatter), and with twice the noise (the same draws doubled) every
    error doubles (the method is linear in the noise at this size: within 10 %)."""
    rng = np.random.default_rng(51)
    err, ratio = [], []
    for _ in range(40):
        locked, R, places, exact = _experiment(rng, 0.0)
        noise = rng.normal(0, SIGMA, exact.shape)
        legs = [
            two_step_leg(
                REFLECTORS,
                STATIONS,
                exact + k * noise,
                np.full(exact.shape, SIGMA),
                R,
                places,
                locked,
            )
            for k in (1, 2)
        ]
        e1, e2 = (np.r_[g.r, g.B, g.l] - np.r_[R_LEG, B_LEG, L0] for g in legs)
        err.append(e1)
        ratio.append(np.linalg.norm(e2) / np.linalg.norm(e1))
    err = np.array(err)
    assert np.all(np.abs(err.mean(axis=0)) < 4 * err.std(axis=0) / np.sqrt(len(err)))
    assert np.all(np.abs(np.array(ratio) - 2) < 0.2)
    assert np.all(err.std(axis=0) > 0)
