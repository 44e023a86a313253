"""OpenCV's pinhole camera with Brown-Conrady distortion, and its analytic Jacobians.

A target point X (target frame, the target's unit) is seen at pixel (u, v):

    X_c = R X + t                      board2cam, R (3, 3), t (3,)
    x, y = X_c[0] / X_c[2], X_c[1] / X_c[2]
    r2 = x^2 + y^2,  radial = 1 + k1 r2 + k2 r2^2 + k3 r2^3
    x_d = x radial + 2 p1 x y + p2 (r2 + 2 x^2)
    y_d = y radial + p1 (r2 + 2 y^2) + 2 p2 x y
    u, v = fx x_d + cx,  fy y_d + cy

Intrinsics in ``INTRINSICS`` order (fx, fy, cx, cy, k1, k2, p1, p2, k3). The pose's derivative is
taken for a left perturbation, R <- exp([w]x) R and t <- t + dt, so its six columns are (w, dt).
"""

from __future__ import annotations

import dataclasses

import numpy as np

INTRINSICS = ("fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3")


@dataclasses.dataclass(frozen=True)
class Projection:
    """Pixels of target points in several views, and their derivatives.

    uv : (n_views, n_points, 2) px.
    d_pose : (n_views, n_points, 2, 6) d(uv) / d(w, dt), the view's own pose.
    d_intrinsics : (n_views, n_points, 2, 9) d(uv) / d(fx, fy, cx, cy, k1, k2, p1, p2, k3).
    """

    uv: np.ndarray
    d_pose: np.ndarray | None
    d_intrinsics: np.ndarray | None


def project(
    intrinsics: np.ndarray,
    board2cam_R: np.ndarray,
    board2cam_t: np.ndarray,
    points: np.ndarray,
    jacobians: bool = True,
) -> Projection:
    """Project ``points`` (n_points, 3) through every view (R (n_views, 3, 3), t (n_views, 3)) of
    a camera with ``intrinsics`` (9,) in ``INTRINSICS`` order; without ``jacobians`` only ``uv``
    (the derivatives are None)."""
    fx, fy, cx, cy, k1, k2, p1, p2, k3 = np.asarray(intrinsics, float)
    Xr = points @ board2cam_R.transpose(0, 2, 1)  # R X, (v, n, 3): the lever arm of a turn
    Xc = Xr + board2cam_t[:, None, :]
    iz = 1.0 / Xc[..., 2]
    x, y = Xc[..., 0] * iz, Xc[..., 1] * iz
    xx, yy, xy = x * x, y * y, x * y
    r2 = xx + yy
    radial = 1 + r2 * (k1 + r2 * (k2 + r2 * k3))
    xd = x * radial + 2 * p1 * xy + p2 * (r2 + 2 * xx)
    yd = y * radial + p1 * (r2 + 2 * yy) + 2 * p2 * xy
    uv = np.stack([fx * xd + cx, fy * yd + cy], axis=-1)
    if not jacobians:
        return Projection(uv, None, None)

    shape = x.shape
    di = np.zeros(shape + (2, 9))
    r4 = r2 * r2
    di[..., 0, 0], di[..., 1, 1] = xd, yd
    di[..., 0, 2], di[..., 1, 3] = 1.0, 1.0
    di[..., 0, 4], di[..., 1, 4] = fx * x * r2, fy * y * r2
    di[..., 0, 5], di[..., 1, 5] = fx * x * r4, fy * y * r4
    di[..., 0, 6], di[..., 1, 6] = fx * 2 * xy, fy * (r2 + 2 * yy)
    di[..., 0, 7], di[..., 1, 7] = fx * (r2 + 2 * xx), fy * 2 * xy
    di[..., 0, 8], di[..., 1, 8] = fx * x * r2 * r4, fy * y * r2 * r4

    # d(x_d, y_d) / d(x, y), then through the normalisation and the pose
    dradial = k1 + r2 * (2 * k2 + 3 * k3 * r2)  # d(radial) / d(r2)
    a = radial + 2 * xx * dradial  # d x_d / d x, without tangential terms
    dxd_dx = a + 2 * p1 * y + 6 * p2 * x
    dxd_dy = 2 * xy * dradial + 2 * p1 * x + 2 * p2 * y
    dyd_dx = 2 * xy * dradial + 2 * p1 * x + 2 * p2 * y
    dyd_dy = radial + 2 * yy * dradial + 6 * p1 * y + 2 * p2 * x
    # d(uv) / d(X_c) = diag(fx, fy) D [[1/z, 0, -x/z], [0, 1/z, -y/z]]
    duv_dX = np.empty(shape + (2, 3))
    for row, f, dx, dy in ((0, fx, dxd_dx, dxd_dy), (1, fy, dyd_dx, dyd_dy)):
        duv_dX[..., row, 0] = f * dx * iz
        duv_dX[..., row, 1] = f * dy * iz
        duv_dX[..., row, 2] = -f * (dx * x + dy * y) * iz
    dp = np.empty(shape + (2, 6))
    # d(X_c) / d(w) = -[R X]x: column k is e_k x (R X)
    dp[..., 0] = duv_dX[..., 2] * Xr[..., None, 1] - duv_dX[..., 1] * Xr[..., None, 2]
    dp[..., 1] = duv_dX[..., 0] * Xr[..., None, 2] - duv_dX[..., 2] * Xr[..., None, 0]
    dp[..., 2] = duv_dX[..., 1] * Xr[..., None, 0] - duv_dX[..., 0] * Xr[..., None, 1]
    dp[..., 3:] = duv_dX
    return Projection(uv, dp, di)
