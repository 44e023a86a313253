"""The covariance of a least-squares estimate, and the test that its normal matrix is regular."""

from __future__ import annotations

import numpy as np
from scipy import sparse

from calibench.estimators.identification.normal import inverse_normal

# kept columns whose variance inflation reaches this repeat each other (see covariance)
MAX_VARIANCE_INFLATION = 1e12


def covariance(J, cost: float) -> tuple[np.ndarray, float]:
    """The estimated parameters' covariance at the minimum of a whitened problem.

    Parameters
    ----------
    J : (m, k) whitened Jacobian of the estimated parameters at the minimum: a numpy array, or a
        scipy.sparse matrix (then the normal matrix is factorised sparsely,
        :func:`~calibench.estimators.identification.normal.inverse_normal`; the test below is
        the same).
    cost : the sum of the squared whitened residuals there.

    Returns
    -------
    cov : (k, k) ``(J^T J)^-1`` times the variance factor (1 when the stated noise is right).
    s2 : the variance factor, ``cost / (m - k)``.

    Raises
    ------
    numpy.linalg.LinAlgError
        When the normal matrix is singular to working precision: a column's variance inflation,
        ``(A^-1)_ii A_ii``, is 1 alone and ``1 / (1 - R^2)`` beside columns that explain it by
        ``R^2``; an identifiable basis keeps none beyond about 1e8, while columns that repeat each
        other to rounding (frames and a tool a degenerate arm cannot tell apart) give about
        1 / eps, a negative variance or a NaN, whichever the rounding picks.
    """
    dof = max(J.shape[0] - J.shape[1], 1)
    s2 = cost / dof
    if sparse.issparse(J):
        A_inv, vif = inverse_normal(J)
        _check(vif)
        return A_inv * s2, s2
    A = J.T @ J
    try:
        A_inv = np.linalg.inv(A)
    except np.linalg.LinAlgError:
        A_inv = np.full_like(A, np.nan)  # exactly singular: said below, as every other kind is
    _check(np.diag(A_inv) * np.diag(A))
    return A_inv * s2, s2


def _check(vif: np.ndarray) -> None:
    """Raise ``LinAlgError`` unless every variance inflation (k,) is a regular matrix's."""
    if not np.all((vif >= 0.5) & (vif < MAX_VARIANCE_INFLATION)):
        raise np.linalg.LinAlgError(
            "the kept parameters' normal matrix is singular to working precision"
        )


def variance_component(e2: np.ndarray, base: np.ndarray, target: float) -> float:
    """v >= 0 with sum(e2 / (base + v)) = target (0 if the stated sigma already covers it)."""

    def chi2(v):
        return float(np.sum(e2 / np.maximum(base + v, 1e-12)))

    if chi2(0.0) <= target:
        return 0.0
    lo, hi = 0.0, float(np.mean(e2)) + 1e-12
    while chi2(hi) > target:
        hi *= 4
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if chi2(mid) > target else (lo, mid)
    return hi
