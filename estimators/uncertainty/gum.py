"""The GUM uncertainty framework (JCGM 100:2008) for a task's output quantities, and its
validation by a Monte Carlo method (JCGM 101:2008 clause 8).

An estimate x (P parameters) with covariance U_x, and a task's output quantities y = f(x) with
Jacobian J = df/dx, shape (Q, P) (or (..., P): one row per point and coordinate), have by the law
of propagation of uncertainty (JCGM 100 5.2.2, eq. 13, in matrix form)

    u^2(y_q) = J_q U_x J_q^T,        U_y = J U_x J^T,

and the coverage interval y +- U_p, U_p = k_p u(y): k_p = 1.96 for p = 95 % under a Gaussian, or
t_p(nu_eff) of a t-distribution with the effective degrees of freedom (JCGM 100 G.4, G.6.4).

The framework is validated against a Monte Carlo interval [y_low, y_high] (JCGM 101 8.1) when

    d_low = |y - U_p - y_low| <= delta   and   d_high = |y + U_p - y_high| <= delta,

delta the numerical tolerance of u(y) (JCGM 101 7.9.2).
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy import stats

from calibench.estimators.uncertainty.adaptive import Adaptive


def propagate(jacobian: np.ndarray, cov: np.ndarray) -> np.ndarray:
    """u(y) of each output quantity: sqrt(J_q U_x J_q^T) (JCGM 100 eq. 13).

    Parameters
    ----------
    jacobian : ndarray, shape (..., P)
        dy/dx of each output quantity (a row per quantity; leading axes as the task has them,
        (Q, P) or per point (Q, D, P)).
    cov : ndarray, shape (P, P)
        U_x, the estimate's covariance.

    Returns
    -------
    ndarray, shape (...)
        The standard uncertainties.
    """
    j = np.asarray(jacobian, float)
    # row by row J_q U_x J_q^T without the (Q, Q) matrix: (J U_x) * J summed over P
    var = np.sum((j @ np.asarray(cov, float)) * j, axis=-1)
    return np.sqrt(np.maximum(var, 0.0))  # rounding of a zero variance may be -1e-30


def output_covariance(jacobian: np.ndarray, cov: np.ndarray) -> np.ndarray:
    """U_y = J U_x J^T, the output quantities' covariance (JCGM 102 6.2.1.3, eq. 3).

    Parameters
    ----------
    jacobian : ndarray, shape (Q, P)
    cov : ndarray, shape (P, P)

    Returns
    -------
    ndarray, shape (Q, Q)
    """
    j = np.asarray(jacobian, float)
    return j @ np.asarray(cov, float) @ j.T


def welch_satterthwaite(contributions: np.ndarray, dof) -> np.ndarray:
    """The effective degrees of freedom of u(y) (JCGM 100 G.4.1, eq. G.2b), uncorrelated inputs.

    nu_eff = u^4(y) / sum_i (c_i u(x_i))^4 / nu_i, u^2(y) = sum_i (c_i u(x_i))^2.

    Parameters
    ----------
    contributions : ndarray, shape (..., P)
        c_i u(x_i) of each input to each output quantity.
    dof : float or ndarray, shape (P,)
        nu_i of each input's u(x_i) (inf: known exactly).

    Returns
    -------
    ndarray, shape (...)
        nu_eff (inf where every contribution has infinite dof).
    """
    c = np.asarray(contributions, float)
    u2 = np.sum(c**2, axis=-1)
    with np.errstate(divide="ignore"):
        denom = np.sum(c**4 / np.asarray(dof, float), axis=-1)
        return np.where(denom > 0, u2**2 / np.where(denom > 0, denom, 1.0), np.inf)


def coverage_factor(p: float = 0.95, dof=None):
    """k_p: the Gaussian's (1 + p)/2 quantile (1.96 at 95 %), or t_p(nu) given dof (G.3.2).

    Parameters
    ----------
    p : float
        The coverage probability.
    dof : float or ndarray, shape (Q,), optional
        nu (or nu_eff) of each u(y); inf is the Gaussian.

    Returns
    -------
    float or ndarray, shape (Q,)
    """
    if dof is None:
        return float(stats.norm.ppf((1 + p) / 2))
    return stats.t.ppf((1 + p) / 2, np.asarray(dof, float))


@dataclasses.dataclass(frozen=True)
class GumInterval:
    """The GUM framework's result per output quantity: ``y``, ``u`` (u(y)), ``k`` (k_p, scalar
    or (Q,)), the interval ``low`` = y - U_p and ``high`` = y + U_p, all of shape (Q,) (or the
    Jacobian's leading shape), and ``p``."""

    y: np.ndarray
    u: np.ndarray
    k: float | np.ndarray
    low: np.ndarray
    high: np.ndarray
    p: float

    @property
    def expanded(self) -> np.ndarray:
        """U_p = k_p u(y)."""
        return np.asarray(self.k * self.u)


def gum_interval(y, jacobian, cov, p: float = 0.95, dof=None) -> GumInterval:
    """y +- k_p u(y) of each output quantity, u(y) by :func:`propagate`.

    Parameters
    ----------
    y : float or ndarray, shape (...)
        The estimates f(x) of the output quantities.
    jacobian : ndarray, shape (..., P)
    cov : ndarray, shape (P, P)
    p : float
        The coverage probability.
    dof : float or ndarray, optional
        nu_eff of u(y) for a t-distribution's k_p (default: the Gaussian's, 1.96 at 95 %).

    Returns
    -------
    GumInterval
    """
    yy = np.asarray(y, float)
    u = propagate(jacobian, cov)
    k = coverage_factor(p, dof)
    return GumInterval(y=yy, u=u, k=k, low=yy - k * u, high=yy + k * u, p=p)


@dataclasses.dataclass(frozen=True)
class Validation:
    """JCGM 101 8.1 per output quantity: ``d_low``, ``d_high``, the tolerance ``delta`` and
    ``validated`` (both d <= delta), shape (Q,) each."""

    d_low: np.ndarray
    d_high: np.ndarray
    delta: np.ndarray
    validated: np.ndarray

    @property
    def overall(self) -> bool:
        """Whether the framework is validated at every quantity."""
        return bool(np.all(self.validated))


def validate(gum: GumInterval, low, high, delta) -> Validation:
    """Compare the GUM framework's interval with a Monte Carlo one (JCGM 101 8.1).

    Parameters
    ----------
    gum : GumInterval
    low, high : ndarray, shape (Q,)
        The Monte Carlo interval's endpoints y_low, y_high (of the same p).
    delta : float or ndarray, shape (Q,)
        The numerical tolerance of u(y) (:func:`~.adaptive.numerical_tolerance`).

    Returns
    -------
    Validation
    """
    d_low = np.abs(gum.low - np.asarray(low, float))
    d_high = np.abs(gum.high - np.asarray(high, float))
    delta = np.broadcast_to(np.asarray(delta, float), d_low.shape)
    return Validation(d_low, d_high, delta, (d_low <= delta) & (d_high <= delta))


def validate_against(gum: GumInterval, mcm: Adaptive) -> Validation:
    """:func:`validate` against an adaptive run's interval and its delta of u(y).

    Parameters
    ----------
    gum : GumInterval
    mcm : Adaptive
        Best run with ``delta_scale=0.2`` (JCGM 101 8.2), of the same p.

    Returns
    -------
    Validation
    """
    if mcm.batches.p != gum.p:
        raise ValueError(f"a {gum.p} GUM interval against a {mcm.batches.p} Monte Carlo one")
    return validate(gum, mcm.low, mcm.high, mcm.delta)
