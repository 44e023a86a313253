"""The reading's resolution read from the values it takes (``noise.resolution``): the count of a
quantised reading, whether it is read on its own grid or rounded again by a finer one, and none
for continuous readings. Tolerances: the count is recovered within 10 % (dense gaps
over a few thousand levels; the rounding again by a grid of 5/7.4 of the count spreads the gaps
over 5 and 10 and their mean over a finite sample stays within a few %)."""

import numpy as np
import pytest

from calibench.estimators.discovery.noise import resolution


def _profile(n: int, rng: np.random.Generator, sweep_mm: float = 16.0) -> np.ndarray:
    """A radius that sweeps ``sweep_mm``, read n times with 2.4 um of scatter (mm)."""
    return 40 + sweep_mm * rng.uniform(size=n) + rng.normal(0, 2.4e-3, n)


@pytest.mark.parametrize("count_um", (1.0, 7.4, 20.0))
def test_a_count_is_read_from_the_values_taken(count_um):
    rng = np.random.default_rng(0)
    q = count_um / 1000
    read = np.round(_profile(12800, rng, sweep_mm=2.0) / q) * q  # every level read
    assert resolution(read) == pytest.approx(q, rel=0.1)


def test_a_count_rounded_again_by_a_finer_grid_is_read_as_its_own_size():
    rng = np.random.default_rng(1)
    count, grid = 7.4e-3, 5e-3  # counts of 7.4 um read by a 5 um encoder: gaps of 5 and 10 um
    read = np.round(np.round(_profile(12800, rng) / count) * count / grid) * grid
    gaps = np.diff(np.unique(read))
    assert set(np.round(gaps[gaps < 0.02] / grid).astype(int)) >= {1, 2}
    assert resolution(read) == pytest.approx(count, rel=0.1)


def test_continuous_readings_have_none():
    rng = np.random.default_rng(2)
    assert resolution(_profile(12800, rng)) == 0.0


def test_a_count_with_levels_left_empty_is_read_larger_never_smaller():
    rng = np.random.default_rng(3)
    q = 1e-3  # 16,000 levels over the sweep, 12,800 readings
    assert resolution(np.round(_profile(12800, rng) / q) * q) >= q


def test_too_few_values_have_no_resolution():
    assert resolution(np.array([1.0, 1.0, 2.0])) == 0.0
