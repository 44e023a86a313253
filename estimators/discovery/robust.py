"""A covariance that still covers when the noise is not as assumed.

Least squares' textbook covariance, sigma^2 (X'X)^-1, assumes readings that are independent with
one variance. Heavy tails and a few gross readings leave least squares unbiased and that formula
valid once sigma is the residuals' own scatter (:func:`fit.fit_terms` takes the larger of that
and the repeatability). A slow drift does not: neighbouring readings share it, and a term whose
column changes slowly in time (a temperature, a pass) is then far less certain than the formula
says.

The residual's autocorrelation is modelled as white noise plus a stationary drift that forgets
exponentially (Ornstein-Uhlenbeck): rho_k = c a^k at lag k. Its two parameters, fitted to the
residual's measured autocorrelation, give the readings' covariance Sigma = s^2 ((1 - c) I + c
a^|i-j|), and the sandwich (X'X)^-1 X' Sigma X (X'X)^-1 is computed exactly by two exponential
filters, without the n x n matrix. A non-parametric sandwich (batches of consecutive readings)
was tried first: over 1,500 readings with a drift correlated over 30 it stated 0.7 of the true
variance, and scattered by 50 % from one recording to the next.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import least_squares, minimize_scalar
from scipy.signal import lfilter

MAX_LAG_SHARE = 0.25  # the autocorrelation is read up to a quarter of each series
LAGS = 16  # lags (geometric, 1 to where it sinks into its noise) the projected fit matches


def _channels(sample: np.ndarray) -> list[np.ndarray]:
    """Row indices of each channel (rows sharing a sample are different channels: x, y, z), each
    in time order."""
    order = np.argsort(sample, kind="stable")
    s = sample[order]
    first = np.r_[0, np.flatnonzero(np.diff(s)) + 1]
    rank = np.arange(len(s)) - np.repeat(first, np.diff(np.r_[first, len(s)]))
    return [order[rank == k] for k in range(int(rank.max()) + 1 if len(s) else 0)]


def autocorrelation(series: list[np.ndarray], max_lag: int) -> np.ndarray:
    """The pooled autocorrelation (max_lag + 1,) of several zero-mean series, lag 0 first."""
    acov, count = np.zeros(max_lag + 1), np.zeros(max_lag + 1)
    for r in series:
        n = len(r)
        f = np.fft.rfft(r, 2 * n)
        full = np.fft.irfft(f * np.conj(f))[: min(max_lag, n - 1) + 1]
        acov[: len(full)] += full
        count[: len(full)] += n - np.arange(len(full))
    acov = acov / np.maximum(count, 1)
    return acov / acov[0] if acov[0] > 0 else np.zeros(max_lag + 1)


def drift_model(series: list[np.ndarray]) -> tuple[float, float]:
    """The share ``c`` of the variance that drifts and its lag-1 memory ``a`` (rho_k = c a^k),
    fitted to the measured autocorrelation up to where it sinks into its own noise."""
    n = sum(len(r) for r in series)
    longest = max((len(r) for r in series), default=0)
    if longest < 16:
        return 0.0, 0.0
    rho = autocorrelation(series, int(MAX_LAG_SHARE * longest))[1:]
    noise = 2.0 / np.sqrt(n)
    below = np.flatnonzero(rho < noise)
    k_max = max(int(below[0]) if len(below) else len(rho), 4)
    k = np.arange(1, k_max + 1, dtype=float)
    if rho[0] < noise:
        return 0.0, 0.0

    def resid(p):
        c, a = p
        return c * a**k - rho[:k_max]

    fit = least_squares(resid, [min(rho[0] / 0.9, 1.0), 0.9], bounds=([0, 0], [1, 0.99999]))
    return float(fit.x[0]), float(fit.x[1])


def _lag_sums(A: np.ndarray, B: np.ndarray, chans: list, lags: np.ndarray) -> np.ndarray:
    """sum_t A[ch[t]] . B[ch[t + k]] over every channel, for each lag k of ``lags``."""
    out = np.zeros(len(lags))
    for i in chans:
        for j, k in enumerate(lags):
            if k < len(i):
                out[j] += float(np.einsum("ij,ij->", A[i[: len(i) - k]], B[i[k:]]))
    return out


def _a_times(U: np.ndarray, chans: list, a: float) -> np.ndarray:
    """A U with A_ij = a^|i-j| within each channel (rows in time order), 0 across channels."""
    W = np.zeros_like(U)
    for i in chans:
        fwd = lfilter([1.0], [1.0, -a], U[i], axis=0)
        bwd = lfilter([1.0], [1.0, -a], U[i][::-1], axis=0)[::-1]
        W[i] = fwd + bwd - U[i]
    return W


def _residual_acov(U: np.ndarray, chans: list, lags: np.ndarray, a: float | None) -> np.ndarray:
    """The expected lag sums of the residual M e, M = I - U U' (U (m, r) orthonormal: the fit's
    columns), for readings e of covariance A (``a``) or the identity (None)."""
    W = U if a is None else _a_times(U, chans, a)
    counts = np.array([sum(max(len(i) - k, 0) for i in chans) for k in lags], float)
    own = counts * (lags == 0) if a is None else counts * a**lags
    G = U.T @ W
    return (
        own
        - _lag_sums(U, W, chans, lags)
        - _lag_sums(W, U, chans, lags)
        + _lag_sums(U @ G, U, chans, lags)
    )


def projected_drift_model(
    X: np.ndarray, res: np.ndarray, chans: list
) -> tuple[float, float, float]:
    """:func:`drift_model`, fitted to what the residual's autocorrelation would be under it
    once the fit's columns ``X`` (m, p) have taken their share: slow columns (a pass, a
    temperature, a direction) soak up part of a drift, so the residual's own autocorrelation
    forgets faster and holds less than the readings' do (fitted as they are, a drift's
    correlation length came out a quarter short, and the variance of slow terms with it).

    Returns ``(c, a, ss)``: the readings' drifting share and memory, and the residual's
    expected sum of squares per unit of the readings' variance (m - p without a drift)."""
    series = [res[i] - res[i].mean() for i in chans]
    c0, a0 = drift_model(series)
    u, sv, _ = np.linalg.svd(np.c_[X, np.ones(len(X))], full_matrices=False)
    U = u[:, sv > sv[0] * 1e-10]
    if c0 <= 0 or a0 <= 0:
        return c0, a0, float(len(res) - U.shape[1])
    rho = autocorrelation(series, int(MAX_LAG_SHARE * max(len(i) for i in chans)))
    below = np.flatnonzero(rho[1:] < 2.0 / np.sqrt(len(res)))
    k_max = max(int(below[0]) if len(below) else len(rho) - 1, 4)
    lags = np.unique(np.r_[0, np.round(np.geomspace(1, k_max, LAGS)).astype(int)])
    white = _residual_acov(U, chans, lags, None)

    def fit_c(a: float) -> tuple[float, float, np.ndarray]:
        drift = _residual_acov(U, chans, lags, a)
        # the residual's autocorrelation is w white/white_0 + (1 - w) drift/drift_0 with w its
        # white share: linear in w
        d = drift[1:] / drift[0] - white[1:] / white[0]
        t = rho[lags[1:]] - white[1:] / white[0]
        w = float(np.clip(d @ t / max(d @ d, 1e-300), 0.0, 1.0))
        return w, float(np.sum((w * d - t) ** 2)), drift

    sol = minimize_scalar(
        lambda v: fit_c(1 - np.exp(v))[1],
        bounds=(np.log((1 - a0) / 8), np.log(min(4 * (1 - a0), 0.5))),
        method="bounded",
        options={"xatol": 0.01},
    )
    a = float(1 - np.exp(sol.x))
    w, _, drift = fit_c(a)
    # back from the residual's drifting share w to the readings' c: w/(1-w) = c d0/((1-c) w0)
    ratio = w / max(1 - w, 1e-12) * white[0] / drift[0]
    c = ratio / (1 + ratio)
    return c, a, float((1 - c) * white[0] + c * drift[0])


def _exp_smooth(X: np.ndarray, a: float) -> np.ndarray:
    """X' A X with A_ij = a^|i-j| (rows in time order), by a forward and a backward filter."""
    fwd = lfilter([1.0], [1.0, -a], X, axis=0)
    bwd = lfilter([1.0], [1.0, -a], X[::-1], axis=0)[::-1]
    return X.T @ fwd + X.T @ bwd - X.T @ X


def long_run_cov(
    X: np.ndarray, res: np.ndarray, sample: np.ndarray, prior: np.ndarray
) -> np.ndarray:
    """The sandwich covariance (p, p) of least squares' coefficients under a slow drift.

    Parameters
    ----------
    X : (m, p) the design's rows, one per reading.
    res : (m,) the residuals of the fit.
    sample : (m,) each row's sample, in time order (rows sharing a sample are channels, each
        with its own drift).
    prior : (q, p) the prior's rows (no noise of their own: they enter the bread, not the meat).

    Returns
    -------
    (p, p) ndarray
        A^-1 B A^-1, A = X'X + P'P, B = X' Sigma X with Sigma from :func:`drift_model`.
    """
    chans = _channels(np.asarray(sample))
    c, a, ss = projected_drift_model(X, res, chans)
    s2 = float(res @ res / max(ss, 1.0))
    B = (1 - c) * (X.T @ X)
    if c > 0:
        B = B + c * sum(_exp_smooth(X[i], a) for i in chans)
    A = X.T @ X + prior.T @ prior
    scale = np.sqrt(np.maximum(np.diag(A), 1e-300))
    Ai = np.linalg.pinv(A / np.outer(scale, scale)) / np.outer(scale, scale)
    return Ai @ B @ Ai * s2


def wider(classical: np.ndarray, sandwich: np.ndarray) -> np.ndarray:
    """The classical covariance (p, p) with each coefficient's variance raised to the
    sandwich's where that is larger; the classical correlations kept."""
    d = np.sqrt(np.maximum(np.diag(classical), 0.0))
    wide = np.sqrt(np.maximum(np.diag(sandwich), d * d))
    ratio = np.divide(wide, d, out=np.ones_like(d), where=d > 0)
    return classical * np.outer(ratio, ratio)
