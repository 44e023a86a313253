"""numpy's median and percentile of a 1-D array, bit for bit, without their first call's import of
``numpy.ma`` (numpy checks its inputs for masked arrays; the import is 20-40 ms of a short
command's start, ``calibench camera``'s)."""

from __future__ import annotations

import numpy as np


def percentile(x: np.ndarray, q: float) -> float:
    """``np.percentile(x, q)`` of a 1-D array with no NaN (its default, linear interpolation).

    Parameters
    ----------
    x : ndarray, shape (n,)
        The values, n >= 1.
    q : float
        The percentile, 0 to 100.

    Returns
    -------
    float
        The value at the virtual index (n - 1) q / 100 of the sorted values, interpolated as
        numpy does (from the upper neighbour when the fraction is one half or more).
    """
    s = np.sort(np.asarray(x, float))
    h = (len(s) - 1) * (q / 100)
    lo = min(int(np.floor(h)), len(s) - 1)
    t = h - lo
    a, b = s[lo], s[min(lo + 1, len(s) - 1)]
    return float(b - (b - a) * (1 - t) if t >= 0.5 else a + (b - a) * t)


def nanmedian(x: np.ndarray) -> float:
    """``np.nanmedian(x)`` of a 1-D array with at least one number: the middle value, or the mean
    of the two middle ones.

    Parameters
    ----------
    x : ndarray, shape (n,)
        The values; NaN are left out.

    Returns
    -------
    float
        The median of the numbers.
    """
    v = np.asarray(x, float)
    v = v[~np.isnan(v)]
    lo, hi = (len(v) - 1) // 2, len(v) // 2
    part = np.partition(v, [lo, hi])
    return float((part[lo] + part[hi]) / 2)
