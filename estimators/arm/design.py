"""Posture design for an arm's identification: the observability index and a D-optimal choice."""

from __future__ import annotations

import numpy as np


def observability_index(J: np.ndarray) -> float:
    """O1 of Borm and Menq: the geometric mean of the singular values of the identification
    Jacobian (columns scaled by :func:`parameter_scales`), over the square root of its rows."""
    sv = np.linalg.svd(J, compute_uv=False)
    return float(np.exp(np.mean(np.log(np.maximum(sv, 1e-300)))) / np.sqrt(J.shape[0]))


def select_postures(J_candidates: np.ndarray, n: int, ridge: float = 1e-6) -> np.ndarray:
    """Greedy D-optimal choice of ``n`` postures from candidates' Jacobian blocks (m, rows, k):
    each step adds the posture that most increases log det(J^T J) (so O1), by the matrix
    determinant lemma on a running inverse. Returns candidate indices, in the order chosen."""
    m, rows, k = J_candidates.shape
    info = ridge * np.eye(k)
    chosen = []
    free = np.ones(m, bool)
    for _ in range(n):
        Minv = np.linalg.inv(info)
        G = np.einsum("mrk,kl,msl->mrs", J_candidates, Minv, J_candidates)
        gain = np.linalg.slogdet(np.eye(rows) + G)[1]
        gain[~free] = -np.inf
        best = int(np.argmax(gain))
        chosen.append(best)
        free[best] = False
        info = info + J_candidates[best].T @ J_candidates[best]
    return np.array(chosen)
