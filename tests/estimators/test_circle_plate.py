"""The circle plate's models (estimators.stage.circle_plate): point pairs made from a known error
field give back its cubic within the reported std, the points' scatter, the periodic term
cross-validation should find, and the plate angle's std."""

import numpy as np

from calibench.estimators.stage.circle_plate import (
    compensation_models,
    fit_plate,
    plate_angle_rad,
)
from calibench.estimators.stage.compensation import LineRuler, monomial_powers

PITCH_MM, NX, NY = 15.0, 20, 13
# the true error (true - reading, um) of each axis: a cubic in the readings (um / mm^k), a0 = 0
# at circle (0, 0); X also has a scale's periodic error along X, of a period the search tries
# (select_model: 60 log-spaced from 20 to 200 mm), so that the best model fits it exactly, and
# long enough that its alias through the 15 mm pitch, 1 / (1 / 15 - 1 / period), is below 20 mm
CUBIC_X = np.array([0.0, 0.19, 0.08, 1.5e-4, -2e-5, -1.1e-4, -3.9e-7, 2e-8, 6e-8, -8e-7])
CUBIC_Y = np.array([0.0, -0.05, 0.12, -1e-4, 6e-5, 2e-5, 3e-7, -1e-7, 4e-8, 2e-7])
PERIOD_MM, AMPLITUDE_UM = float(np.geomspace(20.0, 200.0, 60)[33]), 1.2  # 72.5 mm
SIGMA_UM = 0.3  # each point pair's scatter (the servo and the plate)


def _cubic(c, u, v):
    return np.stack([u**i * v**j for i, j in monomial_powers(3)], axis=-1) @ c


def _true_um(rel):
    u, v = rel[:, 0], rel[:, 1]
    periodic = AMPLITUDE_UM * (np.sin(2 * np.pi * u / PERIOD_MM + 0.4) - np.sin(0.4))
    return np.stack([_cubic(CUBIC_X, u, v) + periodic, _cubic(CUBIC_Y, u, v)], axis=1)


def _point_pairs(rng):
    """Readings (n, 2) mm, circle (0, 0) first, and the circles' nominal positions (n, 2) mm:
    each circle truly lies at its reading plus the error, each reading off by SIGMA_UM, circle
    (0, 0)'s too: every position is taken from that reading, so its error shifts them all."""
    j, i = np.mgrid[0:NY, 0:NX]
    rel = np.stack([i.ravel(), j.ravel()], axis=1) * PITCH_MM
    rel[1:] += rng.uniform(-0.03, 0.03, (len(rel) - 1, 2))  # the servo's last offsets
    readings = np.array([40.0, 25.0]) + rel
    noise = rng.normal(0, SIGMA_UM, rel.shape)
    nominal = rel + (_true_um(rel) + noise - noise[0]) / 1000
    return readings, nominal


def test_the_plate_gives_back_the_cubic_the_scatter_and_the_periodic_term():
    """Over 20 draws the cubic's coefficients scatter about the truth by the reported std (the
    periodic term biases X's cubic, so Y's alone: 200 values, their RMS 1 +- 0.05, the std
    adding the alignment's share to one slope and the datum's to the constant, whose z alone
    is then 1 too: without the datum it would be some sqrt(n / 10) = 5); the points' scatter and
    the periodic error that cross-validation finds along X are the injected ones."""
    z = []
    for seed in range(20):
        readings, nominal = _point_pairs(np.random.default_rng(seed))
        fit = fit_plate(readings, nominal, (NX - 1) * PITCH_MM)
        z.append((fit.cubic[1].coef - CUBIC_Y) / fit.cubic_std[1])
        # n = 260 points: each RMSE within a few percent of the scatter
        assert 0.85 * SIGMA_UM < fit.sigma_um < 1.2 * SIGMA_UM
        x = fit.best[0]
        assert x.period_mm is not None and abs(x.period_mm / PERIOD_MM - 1) < 1e-9, x.name
        assert x.along == 0 and fit.best[1].period_mm is None
        assert abs(np.hypot(*x.coef[-2:]) - AMPLITUDE_UM) < 5 * SIGMA_UM / np.sqrt(130)
    z = np.array(z)
    assert np.all(np.abs(z) < 5)
    assert 0.8 < np.sqrt(np.mean(z**2)) < 1.2
    assert 0.6 < np.sqrt(np.mean(z[:, 0] ** 2)) < 1.5  # 20 values: chi's 99 % band


def test_compensation_models_evaluate_each_model_at_the_readings():
    """The best model leaves the points' scatter; the cubic leaves the periodic error too; the
    line rulers' tables are read per axis."""
    readings, nominal = _point_pairs(np.random.default_rng(3))
    fit = fit_plate(readings, nominal, (NX - 1) * PITCH_MM)
    rulers = [
        LineRuler(np.array([0.0, 400.0]), np.array([1.0, 3.0])),
        LineRuler(np.array([0.0, 400.0]), np.array([-2.0, -2.0])),
    ]
    models = compensation_models(fit, rulers)
    left = {name: fit.err_um - model(readings) for name, model in models.items()}
    rms = {name: np.sqrt(np.mean(r**2, axis=0)) for name, r in left.items()}
    np.testing.assert_allclose(rms["best"], SIGMA_UM, rtol=0.15)
    # what a cubic leaves of the periodic error along X: most of its RMS, amplitude / sqrt(2)
    assert rms["polynomial"][0] > np.hypot(SIGMA_UM, 0.7 * AMPLITUDE_UM / np.sqrt(2))
    np.testing.assert_allclose(rms["polynomial"][1], SIGMA_UM, rtol=0.15)
    np.testing.assert_array_equal(models["uncompensated"](readings), 0.0)
    ruled = models["lineruler"](readings)
    np.testing.assert_allclose(ruled[:, 0], 1.0 + readings[:, 0] / 200.0)
    np.testing.assert_allclose(ruled[:, 1], -2.0)


def test_plate_angle_and_its_std():
    """The angle of a line read at its two ends, and its scatter when each reading scatters as
    the plate's points do: the std fit_plate reports (2000 draws: within 5 %)."""
    rng = np.random.default_rng(5)
    phi = 1.7e-3
    baseline = (NX - 1) * PITCH_MM
    far = np.array([40.0, 25.0]) + baseline * np.array([np.cos(phi), np.sin(phi)])
    assert abs(plate_angle_rad([40.0, 25.0], far) - phi) < 1e-15
    readings, nominal = _point_pairs(rng)
    fit = fit_plate(readings, nominal, baseline)
    noise = rng.normal(0, fit.sigma_um / 1000, (2000, 2, 2))
    angles = [plate_angle_rad(np.array([40.0, 25.0]) + a, far + b) for a, b in noise]
    assert abs(np.std(angles) / fit.phi_std_rad - 1) < 0.05
