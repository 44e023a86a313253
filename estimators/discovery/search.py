"""The kernel of a one-parameter search (a step's moment, a lag's time constant): which of many
candidate columns cuts a residual most beside the columns already in the model, and the residual
sum of squares each leaves (its profile).

For ``y`` (m,), ``X`` (m, p) and candidates ``C`` (m, K), with Q an orthonormal basis of X::

    rss_k = |y - Q Q^T y|^2 - ((c_k - Q Q^T c_k) . (y - Q Q^T y))^2 / |c_k - Q Q^T c_k|^2
"""

from __future__ import annotations

import numpy as np


def profile(y: np.ndarray, X: np.ndarray, C: np.ndarray) -> tuple[int, np.ndarray, float]:
    """The best candidate's index, every candidate's residual sum of squares (K,), and the noise
    variance left at the best (its rss over the degrees of freedom left)."""
    Q, _ = np.linalg.qr(X) if X.shape[1] else (np.zeros((len(y), 0)), None)
    y_left = y - Q @ (Q.T @ y)
    C_left = C - Q @ (Q.T @ C)
    power = np.einsum("ij,ij->j", C_left, C_left)
    gain = np.where(power > 1e-300, (C_left.T @ y_left) ** 2 / np.maximum(power, 1e-300), 0.0)
    best = int(np.argmax(gain))
    rss = float(y_left @ y_left) - gain
    return best, rss, float(rss[best] / max(len(y) - X.shape[1] - 2, 1))


def profile_coefficients(
    y: np.ndarray, X: np.ndarray, C: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Each candidate's own coefficient (K,) beside the columns ``X`` and the power (K,) of
    its column left after them (a coefficient's white-noise variance is sigma^2 over it)."""
    Q, _ = np.linalg.qr(X) if X.shape[1] else (np.zeros((len(y), 0)), None)
    y_left = y - Q @ (Q.T @ y)
    C_left = C - Q @ (Q.T @ C)
    power = np.einsum("ij,ij->j", C_left, C_left)
    return (C_left.T @ y_left) / np.maximum(power, 1e-300), power


def within_one_sigma(grid: np.ndarray, rss: np.ndarray, best: int, sigma2: float) -> float:
    """Half the span of the grid values whose rss is within one noise variance of the best: the
    profile's 1-sigma half-width of the searched parameter."""
    near = grid[rss <= rss[best] + sigma2]
    return float((near.max() - near.min()) / 2)
