"""Rotations and rigid transforms shared by the estimators: one implementation of each."""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation


def skew(v: np.ndarray) -> np.ndarray:
    """Cross-product matrices of vectors, (..., 3) -> (..., 3, 3)."""
    v = np.asarray(v, float)
    S = np.zeros(v.shape[:-1] + (3, 3))
    S[..., 0, 1], S[..., 0, 2], S[..., 1, 2] = -v[..., 2], v[..., 1], -v[..., 0]
    S[..., 1, 0], S[..., 2, 0], S[..., 2, 1] = v[..., 2], -v[..., 1], v[..., 0]
    return S


def rotvec_to_matrix(w: np.ndarray) -> np.ndarray:
    """Rotation vector (3,) rad -> matrix (3, 3) (scipy's Rotation: exact at every angle)."""
    return Rotation.from_rotvec(np.asarray(w, float)).as_matrix()


def rotvecs_to_matrices(w: np.ndarray) -> np.ndarray:
    """Many rotation vectors at once: (n, 3) rad -> (n, 3, 3)."""
    return Rotation.from_rotvec(np.asarray(w, float).reshape(-1, 3)).as_matrix()


def matrix_to_rotvec(R: np.ndarray) -> np.ndarray:
    """Inverse of :func:`rotvec_to_matrix`, (3, 3) -> (3,) rad, angle in [0, pi]. scipy's
    quaternion route keeps full precision for tiny angles (an arccos of the trace loses half the
    digits there: 1 % at 1e-7 rad) and near pi."""
    return Rotation.from_matrix(np.asarray(R, float)).as_rotvec()


def rigid_transform(src: np.ndarray, dst: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Kabsch: R, t minimising sum |R src + t - dst|^2, src (n, 3) not collinear, n >= 3.

    ``dst`` (n, 3) gives R (3, 3), t (3,); a stack (m, n, 3), one fit per set: R (m, 3, 3), t (m, 3).
    """
    src, dst = np.asarray(src, float), np.asarray(dst, float)
    cs, cd = src.mean(axis=0), dst.mean(axis=-2)
    U, _, Vt = np.linalg.svd((src - cs).T @ (dst - cd[..., None, :]))
    V, Ut = np.swapaxes(Vt, -1, -2), np.swapaxes(U, -1, -2)
    d = np.ones(V.shape[:-2] + (3,))
    d[..., 2] = np.sign(np.linalg.det(V @ Ut))
    R = (V * d[..., None, :]) @ Ut
    return R, cd - np.einsum("...ij,j->...i", R, cs)
