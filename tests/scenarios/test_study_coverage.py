"""A study's honesty in a few numbers (scenarios/study/honesty.py), read from summaries that
:func:`summarise` makes of trials drawn here with a known truth: an honest parameter, one biased
by 3 std, and the same trials with every reported std doubled."""

import numpy as np
from scipy.stats import norm

from calibench.scenarios.study.honesty import (
    covered,
    median_std_ratio,
    outside_band,
    pooled_coverage,
    worst_bias,
)
from calibench.scenarios.study.summary import summarise

N = 1000  # trials


def _summary(rng, std_factor=1.0):
    """Trials of three parameters with std 1: 'a' and 'c' honest, 'b' biased by 3 std; each
    reported std ``std_factor`` x the true one; 'd' reports no std."""
    rows = []
    for i in range(N):
        row = {"trial": i, "ok": True}
        for name, bias in (("a", 0.0), ("b", 3.0), ("c", 0.0), ("d", 0.0)):
            row[f"{name}.estimate"] = bias + rng.normal()
            row[f"{name}.truth"] = 0.0
            row[f"{name}.std"] = std_factor if name != "d" else None
            row[f"{name}.unit"] = "mm"
        rows.append(row)
    return summarise("any", rows, 0.0)


def test_pooled_coverage_band_and_worst_bias_are_the_truths():
    """Coverage of a std-1 interval of +-1.96 is 0.95 honest and P(|Z + 3| <= 1.96) biased;
    pooled, their mean, within 5 binomial std; the biased one is outside its band and the worst,
    its bias 3 std within 5 standard errors of the mean."""
    s = _summary(np.random.default_rng(1))
    assert [p["name"] for p in covered(s)] == ["a", "b", "c"]
    p_biased = norm.cdf(1.96 - 3) - norm.cdf(-1.96 - 3)
    expected = (0.95 + p_biased + 0.95) / 3
    binomial_std = np.sqrt((2 * 0.95 * 0.05 + p_biased * (1 - p_biased)) / N) / 3
    assert abs(pooled_coverage(s) - expected) < 5 * binomial_std
    # 'b' always; 'a' and 'c' each with chance 0.05, and with this seed inside their bands
    assert outside_band(s) == 1
    assert not next(
        lo <= p["coverage_95"] <= hi
        for p in covered(s)
        if p["name"] == "b"
        for lo, hi in [p["coverage_95_expected"]]
    )
    name, bias_std = worst_bias(s)
    assert name == "b" and abs(bias_std - 3.0) < 5 / np.sqrt(N)


def test_the_std_ratio_is_the_factor_the_std_grew_by():
    """The same draws with every std doubled: the median ratio is 2, and nothing else moves the
    estimates."""
    before, after = _summary(np.random.default_rng(2)), _summary(np.random.default_rng(2), 2.0)
    assert abs(median_std_ratio(before, after) - 2.0) < 1e-12
    assert [p["bias"] for p in covered(before)] == [p["bias"] for p in covered(after)]
