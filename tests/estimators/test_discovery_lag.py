"""A logged temperature through a lag (``lag.LagSearch``): the time constant and the coefficient
recovered, and their stated std honest over repeated noise draws (mrcal's check), under white
readings and under a slow drift of the readings the fit is not told of.

The truth is made by integrating the part's temperature in time from the air's (an explicit
Euler scheme at a tenth of the sampling step), not by the estimator's closed form. Tolerances:
over 40 draws the share of |z| <= 1.96 scatters by 3.4 % about 0.95; 0.85 is three of that
below; the median |z| is 0.67 for a true std, and at most 1.0 (a std too small by half gives
1.35; the median, not the RMS, so that one draw far in a tail does not decide)."""

import numpy as np
import pytest

from calibench.estimators.discovery.fit import Signal, fit_terms
from calibench.estimators.discovery.lag import LagSearch

N, DT_S = 1200, 20.0  # readings every 20 s over 6.7 h
LAG_S, PPM = 900.0, 15.0


def _part_temperature(t: np.ndarray, air: np.ndarray, tau: float) -> np.ndarray:
    """T' = (T_air - T) / tau, integrated by Euler steps of a tenth of the sampling step on the
    air interpolated linearly."""
    fine = np.arange(t[0], t[-1] + 1e-9, (t[1] - t[0]) / 10)
    a = np.interp(fine, t, air)
    T = np.empty_like(fine)
    T[0] = a[0]
    h = fine[1] - fine[0]
    for i in range(1, len(fine)):
        T[i] = T[i - 1] + h * (a[i - 1] - T[i - 1]) / tau
    return np.interp(t, fine, T)


def _recording(rng: np.random.Generator, drift: bool):
    t = np.arange(N) * DT_S
    air = 20 + 3 * (1 - np.exp(-t / 5400)) + 0.3 * np.sin(2 * np.pi * t / 3000)
    x = rng.uniform(0, 500, N)
    part = _part_temperature(t, air, LAG_S)
    e = PPM * 1e-6 * (part - part.mean()) * x
    sigma = 1e-3
    noise = rng.normal(0, sigma, N)
    if drift:  # a reading that wanders twice the white scatter, over 20 readings (AR(1))
        a = np.exp(-1 / 20)
        w = np.zeros(N)
        kicks = rng.normal(0, 2 * sigma * np.sqrt(1 - a * a), N)
        for i in range(1, N):
            w[i] = a * w[i - 1] + kicks[i]
        noise = noise + w
    base = np.c_[np.ones(N), x]
    sig = Signal("x_meas - x_sim", "x", e + noise, base, np.arange(N))
    return sig, {"x": x, "t_s": t, "temp_c": np.round(air, 3)}


def _z(seed: int, drift: bool) -> tuple[float, float]:
    sig, drivers = _recording(np.random.default_rng(seed), drift)
    fixed, coef, cov, _ = fit_terms(sig, [LagSearch(axis="x")], drivers, {}, None, robust=True)
    term, at, k = fixed[0]
    params, std, _ = term.describe(coef[at : at + k], cov[at : at + k, at : at + k])
    return (
        (params["lag_s"] - LAG_S) / std["lag_s"],
        (params["ppm_per_k"] - PPM) / std["ppm_per_k"],
    )


@pytest.mark.parametrize("drift", [False, True])
def test_the_stated_std_of_a_lag_covers_its_spread(drift):
    z = np.array([_z(seed, drift) for seed in range(40)])
    covered = np.mean(np.abs(z) <= 1.96, axis=0)
    typical = np.median(np.abs(z), axis=0)
    assert covered[0] >= 0.85 and typical[0] <= 1.0, (covered, typical)
    assert covered[1] >= 0.85 and typical[1] <= 1.0, (covered, typical)
