"""The quadratic error map (the seed's Eq. 1) and the cubic ``calibench fit`` reports: synthetic
truth, std honesty, the paper's Table 3."""

import numpy as np
import pytest

from calibench.estimators.stage.error_map import (
    compensated_command,
    fit_cubic,
    fit_quadratic,
    quadratic_coefs,
)
from calibench.recordings import StageRecording
from calibench.scenarios.stage_fit import fit_recording

TRUE = np.array([0.05, 5.9e-3, 1.7e-3, 4.8e-6, -1.26e-6, 3.2e-8])


def _grid():
    x, y = np.meshgrid(np.linspace(0, 980, 11), np.linspace(0, 920, 11))
    return x.ravel(), y.ravel()


def _truth(x, y):
    return TRUE @ np.stack([np.ones_like(x), x, y, x * x, x * y, y * y])


def test_recovers_coefficients_within_their_std_and_the_std_is_honest():
    x, y = _grid()
    rng = np.random.default_rng(7)
    sigma = 0.02
    est, std, rmse = [], [], []
    for _ in range(300):
        f = fit_quadratic(x, y, _truth(x, y) + rng.normal(0, sigma, x.size))
        est.append(f.coef)
        std.append(f.std)
        rmse.append(f.rmse)
    est, std = np.array(est), np.array(std)
    assert np.all(np.abs(est[0] - TRUE) <= 5 * std[0])
    assert np.all(np.abs(est.mean(axis=0) - TRUE) <= 4 * std.mean(axis=0) / np.sqrt(300))
    np.testing.assert_allclose(est.std(axis=0, ddof=1) / std.mean(axis=0), 1, atol=0.15)
    assert np.mean(rmse) == pytest.approx(sigma, rel=0.05)


# a cubic map (mm, mm/mm^k) on 1, x, y, x^2, xy, y^2, x^3, x^2 y, x y^2, y^3
TRUE_CUBIC = np.array([0.02, 2e-4, -1.4e-4, 3e-7, -1e-6, 2e-7, 3e-9, -1e-9, 2e-9, -4e-9])


def _cubic(x, y):
    terms = [x ** (d - j) * y**j for d in range(4) for j in range(d + 1)]
    return TRUE_CUBIC @ np.stack(terms)


def test_cubic_recovers_coefficients_within_their_std_and_the_std_is_honest():
    """300 noise draws on 150 random points: the coefficients scatter about the truth by their
    std (each std's ratio to 1 +- 0.04 over 300 draws: within 0.15), the RMSE is the noise."""
    rng = np.random.default_rng(15)
    x, y = rng.uniform(0, 300, 150), rng.uniform(0, 200, 150)
    sigma = 1e-4
    fits = [fit_cubic(x, y, _cubic(x, y) + rng.normal(0, sigma, x.size)) for _ in range(300)]
    est, std = np.array([f.coef for f in fits]), np.array([f.std for f in fits])
    assert np.all(np.abs(est[0] - TRUE_CUBIC) <= 5 * std[0])
    np.testing.assert_allclose(est.std(axis=0, ddof=1) / std.mean(axis=0), 1, atol=0.15)
    assert np.mean([f.rmse for f in fits]) == pytest.approx(sigma, rel=0.05)
    e = _cubic(x, y) + rng.normal(0, sigma, x.size)
    f = fit_cubic(x, y, e)
    assert f.sse == pytest.approx(f.rmse**2 * (x.size - 10))
    assert f.r2 == pytest.approx(1 - f.sse / np.sum((e - e.mean()) ** 2))
    assert f.as_dict()["n"] == 150 and list(f.as_dict()["coef"]) == [f"a{k}" for k in range(10)]
    assert fit_cubic(x, y, np.full(x.size, 0.3)).r2 is None  # all alike: no R^2


def test_many_maps_at_once_are_each_maps_own_fit():
    """quadratic_coefs (the belt stage's uncertainty propagation fits 20 maps in one solve) gives
    each column's fit_quadratic coefficients."""
    x, y = _grid()
    rng = np.random.default_rng(3)
    E = _truth(x, y)[:, None] + rng.normal(0, 0.01, (len(x), 4)) * np.array([1.0, 0.1, 10.0, 1e-3])
    C = quadratic_coefs(x, y, E)
    assert C.shape == (6, 4)
    for k in range(4):
        own = fit_quadratic(x, y, E[:, k]).coef
        np.testing.assert_allclose(C[:, k], own, rtol=1e-10, atol=1e-12 * np.abs(own).max())


def test_goodness_of_fit_definitions():
    x, y = _grid()
    e = _truth(x, y) + np.random.default_rng(8).normal(0, 0.1, x.size)
    f = fit_quadratic(x, y, e)
    r = e - f(x, y)
    assert f.sse == pytest.approx(r @ r)
    assert f.rmse == pytest.approx(np.sqrt(f.sse / (x.size - 6)))
    assert f.r2 == pytest.approx(1 - f.sse / np.sum((e - e.mean()) ** 2))


def test_degenerate_stations_are_refused():
    x = np.linspace(0, 900, 20)
    with pytest.raises(ValueError, match="degenerate"):
        fit_quadratic(x, np.zeros(20), x * 1e-3)  # one line: y terms undetermined
    with pytest.raises(ValueError, match="more than 6"):
        fit_quadratic(x[:5], x[:5], x[:5])


def test_fitted_map_is_the_truth_between_the_stations():
    """Noise-free errors of the closed-form truth at the stations: the fitted map, evaluated at
    200 random points between them, is the truth to 1e-9 mm (rounding; the maps reach ~10 mm).
    Checks the map's evaluation, every term of it, not only its coefficients."""
    x, y = _grid()
    f = fit_quadratic(x, y, _truth(x, y))
    px, py = np.random.default_rng(9).uniform([0, 0], [980, 920], (200, 2)).T
    np.testing.assert_allclose(f(px, py), _truth(px, py), atol=1e-9)


def test_compensated_command_lands_on_target():
    """Maps fitted to noise-free errors of two closed-form truths: a compensated command plus
    the TRUE error there is the target, to 1e-9 mm (the fixed point converges far below). Checked
    against the truth, not the fitted maps, so a map that evaluates wrongly cannot agree with
    itself."""
    x, y = _grid()
    fx = fit_quadratic(x, y, _truth(x, y))
    fy = fit_quadratic(x, y, 0.5 * _truth(y, x))
    tx, ty = np.array([10.0, 500.0, 990.0]), np.array([900.0, 20.0, 600.0])
    cx, cy = compensated_command(tx, ty, fx, fy)
    np.testing.assert_allclose(cx + _truth(cx, cy), tx, atol=1e-9)
    np.testing.assert_allclose(cy + 0.5 * _truth(cy, cx), ty, atol=1e-9)


def test_paper_table_3(real_data):
    """The seed paper's Table 3, from its measured Tables 1-2 (data/seed_belt_stage):
    SSE 31.96 / 24.08 mm^2, R^2 0.9749 / 0.9833, RMSE 0.5272 / 0.4576 mm."""
    d = real_data / "seed_belt_stage"
    ex = np.loadtxt(d / "x_axis_error_mm.csv", delimiter=",", skiprows=1)
    ey = np.loadtxt(d / "y_axis_error_mm.csv", delimiter=",", skiprows=1)
    assert np.array_equal(ex[:, :2], ey[:, :2])
    rec = StageRecording(
        x_cmd_mm=ex[:, 0],
        y_cmd_mm=ex[:, 1],
        x_meas_mm=ex[:, 0] + ex[:, 2],
        y_meas_mm=ex[:, 1] + ey[:, 2],
    )
    fit = fit_recording("belt-stage", "quadratic", rec)["axes"]
    for axis, sse, r2, rmse in (("x", 31.96, 0.9749, 0.5272), ("y", 24.08, 0.9833, 0.4576)):
        assert round(fit[axis]["sse"], 2) == sse
        assert round(fit[axis]["r2"], 4) == r2
        assert round(fit[axis]["rmse"], 4) == rmse
        assert fit[axis]["n"] == 121
    # the paper's printed coefficients, with the two typesetting slips the data README names
    assert fit["x"]["coef"]["c0"] == pytest.approx(0.1896, abs=1e-4)
    assert fit["y"]["coef"]["c5"] == pytest.approx(3.31e-6, abs=1e-8)
