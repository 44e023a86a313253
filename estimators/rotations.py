"""Rotations and rigid transforms shared by the estimators: one implementation of each."""

from __future__ import annotations

import math

import numpy as np


def skew(v: np.ndarray) -> np.ndarray:
    """Cross-product matrices of vectors, (..., 3) -> (..., 3, 3)."""
    v = np.asarray(v, float)
    S = np.zeros(v.shape[:-1] + (3, 3))
    S[..., 0, 1], S[..., 0, 2], S[..., 1, 2] = -v[..., 2], v[..., 1], -v[..., 0]
    S[..., 1, 0], S[..., 2, 0], S[..., 2, 1] = v[..., 2], -v[..., 1], v[..., 0]
    return S


def rotvecs_to_matrices(w: np.ndarray) -> np.ndarray:
    """Many rotation vectors at once: (n, 3) rad -> (n, 3, 3), Rodrigues' formula.

    Written with half-angle terms, sin(theta) / theta and 2 sin^2(theta / 2) / theta^2, so it is
    exact to rounding at every angle, tiny ones included (1 - cos(theta) would lose the digits
    there); a tenth of scipy's Rotation's time for one vector, which the solvers' steps take."""
    w = np.asarray(w, float).reshape(-1, 3)
    theta = np.sqrt(np.sum(w * w, axis=1))
    half = 0.5 * theta
    tiny = theta < 1e-8  # the series' next terms are below 1e-17 there
    safe = np.where(tiny, 1.0, theta)
    a = np.where(tiny, 1.0 - theta**2 / 6, np.sin(theta) / safe)
    b = np.where(tiny, 0.5 - theta**2 / 24, 2 * (np.sin(half) / safe) ** 2)
    x, y, z = w.T
    R = np.empty((len(w), 3, 3))
    R[:, 0, 0], R[:, 1, 1], R[:, 2, 2] = (
        1 - b * (y * y + z * z),
        1 - b * (x * x + z * z),
        1 - b * (x * x + y * y),
    )
    R[:, 0, 1], R[:, 1, 0] = b * x * y - a * z, b * x * y + a * z
    R[:, 0, 2], R[:, 2, 0] = b * x * z + a * y, b * x * z - a * y
    R[:, 1, 2], R[:, 2, 1] = b * y * z - a * x, b * y * z + a * x
    return R


def rotvec_to_matrix(w: np.ndarray) -> np.ndarray:
    """Rotation vector (3,) rad -> matrix (3, 3), or a stack (..., 3) -> (..., 3, 3):
    :func:`rotvecs_to_matrices`' formula, on scalars for one vector (a solver's step takes one,
    and numpy's per-call cost would be most of the time)."""
    if np.shape(w) != (3,):
        return rotvecs_to_matrices(w).reshape(np.shape(w)[:-1] + (3, 3))
    x, y, z = (float(v) for v in w)
    theta = math.sqrt(x * x + y * y + z * z)
    if theta < 1e-8:
        a, b = 1.0 - theta**2 / 6, 0.5 - theta**2 / 24
    else:
        a, b = math.sin(theta) / theta, 2 * (math.sin(0.5 * theta) / theta) ** 2
    return np.array(
        [
            [1 - b * (y * y + z * z), b * x * y - a * z, b * x * z + a * y],
            [b * x * y + a * z, 1 - b * (x * x + z * z), b * y * z - a * x],
            [b * x * z - a * y, b * y * z + a * x, 1 - b * (x * x + y * y)],
        ]
    )


def matrix_to_rotvec(R: np.ndarray) -> np.ndarray:
    """Inverse of :func:`rotvec_to_matrix`, (3, 3) -> (3,) rad, angle in [0, pi]. The quaternion
    route (Shepperd's choice of its largest component, then 2 atan2(|v|, w)) keeps full precision
    for tiny angles (an arccos of the trace loses half the digits there: 1 % at 1e-7 rad) and
    near pi, as scipy's Rotation does, in a tenth of its time. A stack (..., 3, 3) -> (..., 3)."""
    if np.shape(R) != (3, 3):
        R = np.asarray(R, float)
        return np.array([matrix_to_rotvec(r) for r in R.reshape(-1, 3, 3)]).reshape(
            R.shape[:-2] + (3,)
        )
    (r00, r01, r02), (r10, r11, r12), (r20, r21, r22) = np.asarray(R, float).tolist()
    tr = r00 + r11 + r22
    k = max(range(4), key=(r00, r11, r22, tr).__getitem__)
    if k == 3:
        w, x, y, z = 1 + tr, r21 - r12, r02 - r20, r10 - r01
    elif k == 0:
        w, x, y, z = r21 - r12, 1 + 2 * r00 - tr, r01 + r10, r02 + r20
    elif k == 1:
        w, x, y, z = r02 - r20, r01 + r10, 1 + 2 * r11 - tr, r12 + r21
    else:
        w, x, y, z = r10 - r01, r02 + r20, r12 + r21, 1 + 2 * r22 - tr
    if w < 0:  # the angle in [0, pi]
        w, x, y, z = -w, -x, -y, -z
    v = math.sqrt(x * x + y * y + z * z)
    if v == 0.0:
        return np.zeros(3)
    angle = 2 * math.atan2(v, w)
    return np.array([x, y, z]) * (angle / v)


def rigid_transform(src: np.ndarray, dst: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Kabsch: R, t minimising sum |R src + t - dst|^2, src (n, 3) not collinear, n >= 3.

    ``dst`` (n, 3) gives R (3, 3), t (3,); a stack (m, n, 3), one fit per set: R (m, 3, 3), t (m,
    3).
    """
    src, dst = np.asarray(src, float), np.asarray(dst, float)
    cs, cd = src.mean(axis=0), dst.mean(axis=-2)
    U, _, Vt = np.linalg.svd((src - cs).T @ (dst - cd[..., None, :]))
    V, Ut = np.swapaxes(Vt, -1, -2), np.swapaxes(U, -1, -2)
    d = np.ones(V.shape[:-2] + (3,))
    d[..., 2] = np.sign(np.linalg.det(V @ Ut))
    R = (V * d[..., None, :]) @ Ut
    return R, cd - np.einsum("...ij,j->...i", R, cs)


def rotvecs_to_matrices_scipy(w: np.ndarray) -> np.ndarray:
    """Rotation vectors (n, 3) rad -> matrices (n, 3, 3) by scipy's ``Rotation`` arithmetic,
    operation for operation (its quaternion, its small-angle series below 1e-3 rad, libm's sin
    and cos): bit-identical to ``Rotation.from_rotvec(w).as_matrix()`` (a test checks), without
    importing scipy's spatial transforms (0.2 s, most of a camera calibration's command). For
    the estimators whose published results were made with scipy's.
    """
    w = np.asarray(w, float).reshape(-1, 3)
    out = np.empty((len(w), 3, 3))
    for k, (a, b, c) in enumerate(w.tolist()):
        angle = math.sqrt(a * a + b * b + c * c)
        if angle <= 1e-3:
            angle2 = angle * angle
            scale = 0.5 - angle2 / 48 + angle2 * angle2 / 3840
        else:
            scale = math.sin(angle / 2) / angle
        x, y, z, q = a * scale, b * scale, c * scale, math.cos(angle / 2)
        x2, y2, z2, w2 = x * x, y * y, z * z, q * q
        xy, zw, xz, yw, yz, xw = x * y, z * q, x * z, y * q, y * z, x * q
        out[k] = (
            (x2 - y2 - z2 + w2, 2 * (xy - zw), 2 * (xz + yw)),
            (2 * (xy + zw), -x2 + y2 - z2 + w2, 2 * (yz - xw)),
            (2 * (xz - yw), 2 * (yz + xw), -x2 - y2 + z2 + w2),
        )
    return out


def matrices_to_rotvecs_scipy(R: np.ndarray) -> np.ndarray:
    """Rotation matrices (n, 3, 3) -> rotation vectors (n, 3) rad by scipy's ``Rotation``
    arithmetic (:func:`rotvecs_to_matrices_scipy`'s inverse): bit-identical to
    ``Rotation.from_matrix(R).as_rotvec()`` for orthonormal R; a matrix further than 1e-12 from
    orthonormal goes to scipy itself, which first projects it."""
    R = np.asarray(R, float).reshape(-1, 3, 3)
    gram = R @ R.transpose(0, 2, 1)
    if not np.allclose(gram, np.eye(3), rtol=1e-5, atol=1e-12):  # xpx.isclose's defaults
        from scipy.spatial.transform import Rotation

        return Rotation.from_matrix(R).as_rotvec()
    out = np.empty((len(R), 3))
    for k, m in enumerate(R.tolist()):
        (m00, m01, m02), (m10, m11, m12), (m20, m21, m22) = m
        tr = m00 + m11 + m22
        choice = max(range(4), key=[m00, m11, m22, tr].__getitem__)
        if choice == 0:
            q = [1 - tr + 2 * m00, m10 + m01, m20 + m02, m21 - m12]
        elif choice == 1:
            q = [m10 + m01, 1 - tr + 2 * m11, m21 + m12, m02 - m20]
        elif choice == 2:
            q = [m20 + m02, m21 + m12, 1 - tr + 2 * m22, m10 - m01]
        else:
            q = [m21 - m12, m02 - m20, m10 - m01, 1 + tr]
        n = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
        q = [v / n for v in q]
        if (q[3], q[0], q[1], q[2]) < (0.0, 0.0, 0.0, 0.0):  # the canonical sign: w >= 0 first
            q = [-v for v in q]
        ax = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2])
        angle = 2 * math.atan2(ax, q[3])
        if angle <= 1e-3:
            angle2 = angle * angle
            scale = 2 + angle2 / 12 + 7 * angle2 * angle2 / 2880
        else:
            scale = angle / math.sin(angle / 2.0)
        out[k] = (scale * q[0], scale * q[1], scale * q[2])
    return out
