"""Coverage intervals from Monte Carlo trials, as JCGM 101:2008 clause 7.7 forms them.

Of M sorted model values y_(1) <= ... <= y_(M) of one output quantity, a coverage interval for
probability p is [y_(r), y_(r+q)] with q = pM when pM is an integer, else the integer part of
pM + 1/2 (7.7.1). The probabilistically symmetric interval takes r = (M - q)/2 when M - q is
even, else (M - q + 1)/2 (7.7.1); the shortest takes the r in 1 .. M - q of least
y_(r+q) - y_(r) (7.7.2). These are order statistics, not numpy's interpolated percentile
(:mod:`calibench.estimators.quantiles`, which other estimators use for a median or a band).
"""

from __future__ import annotations

import numpy as np


def coverage_count(m: int, p: float) -> int:
    """q of JCGM 101 7.7.1: how many of M sorted values an interval of probability p spans.

    Parameters
    ----------
    m : int
        The number of trials M.
    p : float
        The coverage probability, 0 < p < 1.

    Returns
    -------
    int
        q = pM if pM is an integer, else the integer part of pM + 1/2.
    """
    # pM is an integer up to rounding (0.95 * 10^4 = 9500.000000000002): half a unit rounds it
    return int(np.floor(p * m + 0.5))


def coverage_interval(
    values: np.ndarray, p: float = 0.95, shortest: bool = False
) -> tuple[np.ndarray, np.ndarray]:
    """The coverage interval [y_(r), y_(r+q)] of each output quantity's trials (JCGM 101 7.7).

    Parameters
    ----------
    values : ndarray, shape (M, Q)
        M model values of each of Q output quantities (one column a quantity).
    p : float
        The coverage probability.
    shortest : bool
        The shortest interval (7.7.2) instead of the probabilistically symmetric one (7.7.1).

    Returns
    -------
    low, high : ndarray, shape (Q,)
        The endpoints y_low = y_(r), y_high = y_(r+q) of each quantity.
    """
    v = np.asarray(values, float)
    m = v.shape[0]
    q = coverage_count(m, p)
    if not 0 < q < m:
        raise ValueError(f"{m} trials hold no interval of probability {p}")
    if not shortest:
        r = (m - q) // 2 if (m - q) % 2 == 0 else (m - q + 1) // 2
        # two order statistics a quantity, not a sort: each quantity's values contiguous (a copy,
        # partitioned in place), y_(r) selected, then y_(r+q) among the values above it (four
        # times faster than numpy's two-kth partition down the columns)
        t = np.array(v.T, order="C")
        t.partition(r - 1, axis=1)  # 1-based y_(r) is column r - 1
        upper = t[:, r:]
        upper.partition(q - 1, axis=1)
        return t[:, r - 1].copy(), upper[:, q - 1].copy()
    return shortest_choice(shortest_candidates(v, p))[:2]


def shortest_candidates(values: np.ndarray, p: float = 0.95) -> np.ndarray:
    """Every candidate [y_(r), y_(r+q)], r = 1 .. M - q, of the shortest interval (7.7.2).

    Averaged over batches (elementwise, a candidate being a pair of fixed order statistics) they
    give the shortest interval of many batches without the downward bias of averaging each
    batch's own shortest one (the least of M - q noisy widths: about 0.02 u(y) at M = 10^4).

    Parameters
    ----------
    values : ndarray, shape (M, Q)
    p : float

    Returns
    -------
    ndarray, shape (2, M - q, Q)
        The candidates' lower endpoints y_(1) .. y_(M-q) and upper ones y_(q+1) .. y_(M).
    """
    v = np.asarray(values, float)
    m = v.shape[0]
    q = coverage_count(m, p)
    if not 0 < q < m:
        raise ValueError(f"{m} trials hold no interval of probability {p}")
    s = np.sort(v, axis=0)
    return np.stack([s[: m - q], s[q:]])


def shortest_choice(candidates: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The shortest of the candidates of :func:`shortest_candidates` (or of their averages).

    Parameters
    ----------
    candidates : ndarray, shape (2, K, Q)

    Returns
    -------
    low, high, index : ndarray, shape (Q,)
        The endpoints of each quantity's shortest candidate (the first of least width) and its
        index k (r - 1).
    """
    k = np.argmin(candidates[1] - candidates[0], axis=0)
    pick = k[None, None, :]
    chosen = np.take_along_axis(candidates, np.broadcast_to(pick, (2, 1, k.size)), 1)[:, 0]
    return chosen[0], chosen[1], k
