"""estimators/quantiles.py against numpy's own percentile and nanmedian: the same float, bit for
bit, on arrays of every length from 1 to 120 (odd and even, ties, NaN among them), at the
percentiles the estimators use and at the interpolation's edge cases."""

import numpy as np

from calibench.estimators.quantiles import nanmedian, percentile


def test_percentile_is_numpys():
    rng = np.random.default_rng(21)
    for n in range(1, 121):
        x = rng.normal(10.0, 3.0, n)
        if n % 7 == 0:
            x = np.round(x)  # ties
        for q in (0.0, 5.0, 10.0, 25.0, 50.0, 90.0, 99.5, 100.0, float(rng.uniform(0, 100))):
            assert percentile(x, q) == np.percentile(x, q), (n, q)


def test_nanmedian_is_numpys():
    rng = np.random.default_rng(22)
    for n in range(1, 121):
        x = rng.exponential(2.0, n)
        x[rng.random(n) < 0.3] = np.nan
        if np.all(np.isnan(x)):
            x[0] = 1.5
        assert nanmedian(x) == np.nanmedian(x), n
