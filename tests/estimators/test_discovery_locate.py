"""The engine's location step (:func:`calibench.estimators.discovery.locate.follows`) on synthetic
residuals of a known structure: each null finds what it is for, keeps a recording's own order
from passing for a driver, and says which of a point's coordinates scored."""

import numpy as np
import pytest

from calibench.estimators.discovery.locate import Driver, follows

N = 600
NOISE = 1e-3


def test_a_short_pitch_along_a_driver_is_found_by_its_neighbours_not_by_bins():
    """A 4 mm period of 3 um along 300 mm of length, rows in random order: binned means over
    eighths of the travel average it away (p > 0.05), the neighbours' correlation does not."""
    rng = np.random.default_rng(1)
    L = rng.uniform(600, 900, N)
    r = 3 * NOISE * np.sin(2 * np.pi * L / 4.0) + rng.normal(0, NOISE, N)
    passes = np.zeros(N)
    (found,) = follows(r, [Driver("length", L, "along")], passes, np.random.default_rng(0))
    assert found.p <= 0.01 and found.score > 0.3
    assert not follows(r, [Driver("length", L, "shift")], passes, np.random.default_rng(0), 0.05)


def test_a_drift_on_a_path_there_and_back_does_not_pass_for_the_position():
    """Four passes along x, there and back, the residual a drift in time: against x (each pass
    shifted cyclically) it is not kept; against time, the values shuffled (rows as recorded), it
    is."""
    rng = np.random.default_rng(2)
    leg = np.linspace(0, 500, N // 4)
    x = np.r_[leg, leg[::-1], leg, leg[::-1]]
    t = np.arange(N, dtype=float)
    r = 5 * NOISE * t / N + rng.normal(0, NOISE, N)
    passes = np.repeat(np.arange(4), N // 4)
    kept = follows(r, [Driver("x", x), Driver("t_s", t, "shuffle")], passes, rng)
    assert [f.name for f in kept] == ["t_s"], kept


def test_the_best_coordinate_of_a_point_is_the_one_reported():
    """A point's three residuals, the joint angle's effect on z only: kept, column 2."""
    rng = np.random.default_rng(3)
    q = rng.uniform(-3, 3, N)
    r = rng.normal(0, NOISE, (N, 3))
    r[:, 2] += 2 * NOISE * np.sin(q)
    (found,) = follows(r, [Driver("q2", q)], np.zeros(N), rng, n_perm=99)
    assert found.column == 2 and found.name == "q2"


def test_on_noise_each_null_keeps_a_driver_as_often_as_its_p_max_says():
    """White noise against one driver of each null, 40 draws at p_max 0.05: each null keeps the
    driver in at most 7 of 40 (the binomial's 99.9 % bound for a true rate of 0.05; a null that
    ignores the order it keeps, or a p-value off by its +1, fails)."""
    rng = np.random.default_rng(4)
    kept = dict.fromkeys(("shift", "passes", "shuffle", "along"), 0)
    passes = np.repeat(np.arange(6), N // 6)
    for _ in range(40):
        v = rng.uniform(0, 1, N)
        r = rng.normal(0, NOISE, N)
        for null in kept:
            kept[null] += len(follows(r, [Driver("v", v, null)], passes, rng, 0.05, 0.0, 99))
    assert max(kept.values()) <= 7, kept


def test_an_unknown_null_is_refused():
    with pytest.raises(ValueError, match="unknown null"):
        Driver("x", np.arange(3.0), "cyclic")
