"""The seed arm's coverage under a wrong datasheet (scenarios/arm_cmm/datasheet.py): with the
stated sigma 1.5x too large or too small, the reported std (which carry the residuals' variance
factor) cover 95 %, and without that factor they cover what a std scaled by the factor would:
P(|Z| <= 1.96 x 1.5) and P(|Z| <= 1.96 / 1.5)."""

import numpy as np
import pytest
from scipy.stats import norm

from calibench.scenarios.arm_cmm.datasheet import Z_95, datasheet_coverage

TRIALS = 100
PER_TRIAL = 18  # parameters with a reference in each trial of the seed's arm


@pytest.mark.parametrize("factor", [1.5, 1 / 1.5])
def test_coverage_with_and_without_the_variance_factor(factor):
    """Tolerance: 4 binomial std of TRIALS x PER_TRIAL draws, times 1.5 for the correlation of
    the parameters within a trial."""
    with_factor, without = datasheet_coverage(factor, TRIALS)
    for got, p in ((with_factor, 0.95), (without, 2 * norm.cdf(Z_95 * factor) - 1)):
        tol = 4 * 1.5 * np.sqrt(p * (1 - p) / (TRIALS * PER_TRIAL))
        assert abs(got - p) < tol, (factor, got, p, tol)
