"""The blinded recordings' reading noise (sim.concealed.noise): each kind has the statistics it
claims, and ``gaussian`` is bit for bit what the recordings drew before the other kinds."""

import numpy as np
import pytest
from scipy import stats

from calibench.sim.concealed import scanner_recording, stage_recording
from calibench.sim.concealed.noise import (
    DRIFT_SHARE,
    OUTLIER_SHARE,
    OUTLIER_SIGMAS,
    reading_noise,
)

N, SIGMA = 200_000, 2.0


def test_gaussian_is_the_generator_s_own_normal():
    a = reading_noise("gaussian", np.random.default_rng(5), (N, 2), SIGMA)
    b = np.random.default_rng(5).normal(0, SIGMA, (N, 2))
    assert np.array_equal(a, b)


def test_t3_has_the_stated_spread_and_heavy_tails():
    e = reading_noise("t3", np.random.default_rng(1), (N,), SIGMA)
    # the interquartile range of t3 scaled to std sigma (t3's variance is 3)
    iqr = 2 * stats.t.ppf(0.75, 3) * SIGMA / np.sqrt(3)
    assert np.subtract(*np.percentile(e, [75, 25])) == pytest.approx(iqr, rel=0.02)
    beyond = np.mean(np.abs(e) > 3 * SIGMA)
    want = 2 * stats.t.sf(3 * np.sqrt(3), 3)  # one in 72, a Gaussian's one in 370
    assert beyond == pytest.approx(want, abs=5 * np.sqrt(want / N))


def test_drift_is_white_plus_a_slow_correlated_part():
    n = 20_000
    e = reading_noise("drift", np.random.default_rng(2), (n, 3), SIGMA)
    a = np.exp(-1 / (DRIFT_SHARE * n))
    for k in (1, 50, 400):  # white + OU of equal variance: correlation a^k / 2 at lag k
        r = np.mean([np.corrcoef(e[:-k, j], e[k:, j])[0, 1] for j in range(3)])
        # the estimate's scatter: about sqrt(correlation time / n) for a slow process
        assert r == pytest.approx(a**k / 2, abs=0.12), k
    assert np.std(e) == pytest.approx(np.sqrt(2) * SIGMA, rel=0.15)


def test_outliers_are_a_few_gross_readings_on_gaussian_noise():
    e = reading_noise("outliers", np.random.default_rng(3), (N, 2), SIGMA)
    gross = np.abs(e) > (OUTLIER_SIGMAS[0] - 3) * SIGMA  # no Gaussian reading gets to 7 sigma
    assert gross.sum() == round(OUTLIER_SHARE * e.size)
    assert np.abs(e[gross]).max() <= (OUTLIER_SIGMAS[1] + 6) * SIGMA
    assert np.std(e[~gross]) == pytest.approx(SIGMA, rel=0.01)


def test_an_unknown_kind_is_refused():
    with pytest.raises(ValueError, match="unknown noise"):
        reading_noise("cauchy", np.random.default_rng(0), (3,), 1.0)


def test_recordings_take_the_noise_they_are_given():
    g, manifest = stage_recording("vision-stage", "null", 3)
    same, _ = stage_recording("vision-stage", "null", 3, noise="gaussian")
    heavy, m_heavy = stage_recording("vision-stage", "null", 3, noise="outliers")
    assert np.array_equal(g.x_meas_mm, same.x_meas_mm)
    assert manifest["noise"] == "gaussian" and m_heavy["noise"] == "outliers"
    jump = np.abs(heavy.x_meas_mm - g.x_meas_mm)
    assert np.sum(jump > 5e-3) >= 1  # a gross reading, 10+ um on a 1 um reference
    s1, _ = scanner_recording("null", 3, noise="gaussian")
    s2, _ = scanner_recording("null", 3, noise="t3")
    assert not np.array_equal(s1.rho_mm, s2.rho_mm)
