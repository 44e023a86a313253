"""Pose of a planar target in the camera frame (``board2cam``): closed form and refined.

``board2cam`` maps board-frame points X (mm, z = 0 on the target) to the OpenCV camera frame:
``x_cam = R @ X + t``. Rotations are (3, 3), translations (3,) in the board's unit.
"""

from __future__ import annotations

import dataclasses

import cv2
import numpy as np

_UNDISTORT = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 50, 1e-12)


def undistort_pixels(pixels: np.ndarray, K: np.ndarray, dist: np.ndarray) -> np.ndarray:
    """Distorted pixels to ideal (pinhole) pixels of the same camera, shape (n, 2)."""
    pts = np.asarray(pixels, np.float64).reshape(-1, 1, 2)
    if hasattr(cv2, "undistortPointsIter"):  # OpenCV 4
        return cv2.undistortPointsIter(pts, K, dist, None, K, _UNDISTORT).reshape(-1, 2)
    return cv2.undistortPoints(pts, K, dist, R=None, P=K, criteria=_UNDISTORT).reshape(-1, 2)


def homography(board_xy: np.ndarray, pixels: np.ndarray) -> np.ndarray:
    """Least-squares homography (normalised DLT) from board xy to pixels, (n, 2) -> (3, 3)."""
    return homographies(np.asarray(board_xy, float), np.asarray(pixels, float)[None])[0]


def homographies(board_xy: np.ndarray, pixels: np.ndarray) -> np.ndarray:
    """Each view's least-squares homography from board xy to pixels (normalised DLT), all views
    at once: board_xy (n, 2), pixels (n_views, n, 2) with NaN rows left out, H (n_views, 3, 3)
    scaled to H[2, 2] = 1."""
    kept = np.isfinite(pixels).all(axis=2)
    w = kept.astype(float)
    cnt = w.sum(axis=1)
    # Hartley's normalisation: the board's points once, each view's pixels on their own
    mb = board_xy.mean(axis=0)
    sb = np.sqrt(2) / np.mean(np.linalg.norm(board_xy - mb, axis=1))
    X = (board_xy - mb) * sb  # (n, 2)
    p = np.where(kept[..., None], pixels, 0.0)
    mp = p.sum(axis=1) / cnt[:, None]
    sp = np.sqrt(2) * cnt / np.sum(np.linalg.norm(p - mp[:, None], axis=2) * w, axis=1)
    u = (p - mp[:, None]) * sp[:, None, None]  # (v, n, 2)
    n_views, n = u.shape[:2]
    A = np.zeros((n_views, n, 2, 9))
    Xh = np.c_[X, np.ones(n)]
    A[:, :, 0, 0:3] = Xh
    A[:, :, 0, 6:9] = -u[..., 0:1] * Xh
    A[:, :, 1, 3:6] = Xh
    A[:, :, 1, 6:9] = -u[..., 1:2] * Xh
    A = (A * w[..., None, None]).reshape(n_views, 2 * n, 9)
    # the null vector from A^T A (9 x 9): normalised, its squared conditioning costs no digit a
    # starting pose needs, and it is a fraction of the SVD of A's 2 n rows
    ev, V = np.linalg.eigh(A.transpose(0, 2, 1) @ A)
    if np.any(ev[:, 1] < 1e-18 * ev[:, -1]):
        raise ValueError("a view's corners are collinear: no homography")
    Hn = V[:, :, 0].reshape(n_views, 3, 3)
    Tb = np.array([[sb, 0, -sb * mb[0]], [0, sb, -sb * mb[1]], [0, 0, 1]])
    Tp_inv = np.zeros((n_views, 3, 3))
    Tp_inv[:, 0, 0] = Tp_inv[:, 1, 1] = 1 / sp
    Tp_inv[:, :2, 2] = mp
    Tp_inv[:, 2, 2] = 1
    H = Tp_inv @ Hn @ Tb
    return H / H[:, 2:, 2:]


def board2cam_from_homography(H: np.ndarray, K: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Closed-form extrinsics from H = s K [r1 r2 t] (Zhang; the seed paper's Eq. 13-18).

    lambda = 1 / |K^-1 h1|, r1 = lambda K^-1 h1, r2 = lambda K^-1 h2, r3 = r1 x r2,
    t = lambda K^-1 h3; the sign makes the target lie in front of the camera, and the
    nearest rotation (SVD) replaces the noisy [r1 r2 r3]. H (3, 3) gives R (3, 3), t (3,);
    a stack H (n, 3, 3) gives R (n, 3, 3), t (n, 3).
    """
    Hs = np.asarray(H, float)
    A = (
        np.linalg.solve(K, Hs.reshape(-1, 3, 3).transpose(1, 0, 2).reshape(3, -1))
        .reshape(3, -1, 3)
        .transpose(1, 0, 2)
    )
    lam = 1.0 / np.linalg.norm(A[:, :, 0], axis=1)
    lam = np.where(A[:, 2, 2] * lam < 0, -lam, lam)[:, None]
    r1, r2, t = lam * A[:, :, 0], lam * A[:, :, 1], lam * A[:, :, 2]
    U, _, Vt = np.linalg.svd(np.stack([r1, r2, np.cross(r1, r2)], axis=2))
    D = np.ones((len(A), 3))
    D[:, 2] = np.linalg.det(U @ Vt)
    R = (U * D[:, None, :]) @ Vt
    return (R[0], t[0]) if Hs.ndim == 2 else (R, t)


def board2cam_pnp(
    board_points: np.ndarray,
    pixels: np.ndarray,
    K: np.ndarray,
    dist: np.ndarray,
    guess: tuple[np.ndarray, np.ndarray] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """Maximum-likelihood pose (Levenberg-Marquardt on reprojection error), R (3, 3), t (3,);
    without a ``guess``, from OpenCV's iterative PnP's."""
    obj = np.asarray(board_points, np.float64)
    img = np.asarray(pixels, np.float64)
    if guess is None:
        ok, rvec, tvec = cv2.solvePnP(obj, img, K, dist, flags=cv2.SOLVEPNP_ITERATIVE)
        if not ok:
            raise ValueError("PnP failed")
        guess = cv2.Rodrigues(rvec)[0], tvec.ravel()
    R, t = board2cam_refine(
        obj,
        img[None],
        K,
        dist,
        np.asarray(guess[0], float)[None],
        np.asarray(guess[1], float)[None],
    )
    return R[0], t[0]


XTOL = 1e-8  # a refinement's last step, in units of each pose parameter's std
SIGMA_FLOOR_PX = 1e-3  # the residual's scale XTOL is taken of, at least


def board2cam_refine(
    board_points: np.ndarray,
    pixels: np.ndarray,
    K: np.ndarray,
    dist: np.ndarray,
    R: np.ndarray,
    t: np.ndarray,
    max_iter: int = 50,
) -> tuple[np.ndarray, np.ndarray]:
    """Maximum-likelihood poses of several views at once, refined from R (n, 3, 3), t (n, 3).

    Levenberg-Marquardt on each view's reprojection error (pixels (n, m, 2) of board_points
    (m, 3); a NaN row is a corner left out), each view with its own damping. A view is done
    when its step moves no pose parameter by more than ``XTOL`` of its std. OpenCV's
    ``solvePnP`` stops at a relative change of 1.2e-7 instead, which leaves a pose's last digits
    to its start (a belt-stage map coefficient moved by 1e-3 std with a 1e-14 change of the
    intrinsics).
    Raises ValueError when a view does not converge.

    Not on the identification core: hundreds of independent 6-parameter problems solved side by
    side, each with its own damping (vectorised over the views), with nothing for a basis to
    drop; the core solves one problem at a time.
    """
    from calibench.estimators.camera.projection import project
    from calibench.estimators.rotations import rotvecs_to_matrices_scipy

    obj = np.asarray(board_points, float)
    pix = np.asarray(pixels, float)
    kept = np.repeat(np.isfinite(pix).all(axis=2), 2, axis=1)  # (n, 2 m)
    pix = np.where(np.isfinite(pix), pix, 0.0).reshape(len(pix), -1)
    intrinsics = np.r_[K[0, 0], K[1, 1], K[0, 2], K[1, 2], np.r_[np.ravel(dist), np.zeros(5)][:5]]
    R, t = np.array(R, float), np.array(t, float)

    def residuals(R, t, jacobians):
        P = project(intrinsics, R, t, obj, jacobians=jacobians)
        r = np.where(kept, pix - P.uv.reshape(len(R), -1), 0.0)
        return r, (P.d_pose.reshape(len(R), -1, 6) * kept[..., None] if jacobians else None)

    dof = np.maximum(kept.sum(axis=1) - 6, 1)
    r, J = residuals(R, t, True)
    cost = np.sum(r * r, axis=1)
    lam = np.full(len(R), 1e-3)
    done = np.zeros(len(R), bool)
    converged = np.zeros(len(R), bool)
    for _ in range(max_iter):
        A = J.transpose(0, 2, 1) @ J
        g = (J.transpose(0, 2, 1) @ r[..., None])[..., 0]
        diag = np.diagonal(A, axis1=1, axis2=2)
        step = np.linalg.solve(A + lam[:, None, None] * diag[:, :, None] * np.eye(6), g[..., None])[
            ..., 0
        ]
        step[done] = 0.0
        R_new = rotvecs_to_matrices_scipy(step[:, :3]) @ R
        t_new = t + step[:, 3:]
        r_new, _ = residuals(R_new, t_new, False)
        cost_new = np.sum(r_new * r_new, axis=1)
        # floored as the calibration's is (zhang.SIGMA_FLOOR_PX): on corners without noise
        # XTOL of a smaller scale asks for steps under float64's rounding of the pixels
        sigma = np.maximum(np.sqrt(cost / dof), SIGMA_FLOOR_PX)
        size = (
            np.max(np.abs(step) * np.sqrt(diag), axis=1) / sigma
        )  # in units of each parameter's std
        # a step under 1e-3 std is taken whatever the cost says: the cost's own rounding (1e-12 of
        # it, the residuals being differences of pixel coordinates) hides a change that small
        better = ((cost_new < cost) | (size < 1e-3)) & ~done
        R[better], t[better], cost[better] = R_new[better], t_new[better], cost_new[better]
        lam = np.where(better, np.maximum(lam / 10, 1e-12), lam * 10)
        # at a minimum: a step below the tolerance, or no damping lowers the cost and the gradient
        # vanishes
        small = size < XTOL
        stuck = ~better & (lam > 1e10)
        flat = np.max(np.abs(g) / np.sqrt(np.maximum(diag, 1e-300)), axis=1) < XTOL * np.maximum(
            np.sqrt(cost), 1e-9
        )
        converged |= ~done & (small | (stuck & flat))
        done |= small | stuck
        if done.all():
            break
        r, J = residuals(R, t, True)
    if not converged.all():
        raise ValueError(
            f"PnP did not converge for view(s) {np.flatnonzero(~converged)[:5].tolist()}"
        )
    return R, t


# projectPoints' Jacobian columns after (rvec, tvec): fx, fy, cx, cy, then k1, k2, p1, p2, k3
_INTRINSIC_COLUMN = {
    "fx": 6,
    "fy": 7,
    "cx": 8,
    "cy": 9,
    "k1": 10,
    "k2": 11,
    "p1": 12,
    "p2": 13,
    "k3": 14,
}


def pose_sensitivity(
    board_points: np.ndarray,
    R: np.ndarray,
    t: np.ndarray,
    K: np.ndarray,
    dist: np.ndarray,
    names: tuple[str, ...],
) -> np.ndarray:
    """How the PnP pose moves with the intrinsics ``names``, d(rvec, t) / d(intrinsics), (6, k).

    The implicit-function theorem at the reprojection minimum, J_pose^T r = 0: d pose / d theta
    = -(J_pose^T J_pose)^-1 J_pose^T J_theta (Gauss-Newton: the residuals' own second-order
    term is left out, the residuals being hundredths of a pixel). rvec is Rodrigues' vector of
    ``R`` (3, 3); t (3,) in the board's unit; board_points (m, 3). Several poses at once: R
    (n, 3, 3), t (n, 3) give (n, 6, k).
    """
    R, t = np.asarray(R, float), np.asarray(t, float)
    if R.ndim == 2:
        return pose_sensitivity(board_points, R[None], t[None], K, dist, names)[0]
    obj = np.asarray(board_points, np.float64)
    jac = np.stack(
        [
            cv2.projectPoints(obj, cv2.Rodrigues(Ri)[0], ti.reshape(3, 1), K, dist)[1]
            for Ri, ti in zip(R, t)
        ]
    )
    Jp = jac[:, :, :6]
    Jt = jac[:, :, [_INTRINSIC_COLUMN[n] for n in names]]
    JpT = Jp.transpose(0, 2, 1)
    return -np.linalg.solve(JpT @ Jp, JpT @ Jt)


def mean_rotation(R: np.ndarray) -> np.ndarray:
    """Chordal L2 mean of rotations, (n, 3, 3) -> (3, 3)."""
    U, _, Vt = np.linalg.svd(np.sum(R, axis=0))
    return U @ np.diag([1, 1, np.linalg.det(U @ Vt)]) @ Vt


@dataclasses.dataclass(frozen=True)
class Plane:
    """A plane fitted to points: centroid (3,), unit normal (3,), in-plane basis (3, 2), and the
    covariance (2, 2) of its slopes (rad) along the two basis directions."""

    centroid: np.ndarray
    normal: np.ndarray
    basis: np.ndarray
    slope_cov: np.ndarray

    def tilted(self, slopes: np.ndarray) -> Plane:
        """The plane through the same centroid with extra slopes (2,) along its basis."""
        n = self.normal - self.basis @ np.asarray(slopes, float)
        n /= np.linalg.norm(n)
        B = self.basis - np.outer(n, n @ self.basis)
        B[:, 0] /= np.linalg.norm(B[:, 0])
        B[:, 1] -= B[:, 0] * (B[:, 0] @ B[:, 1])
        B[:, 1] /= np.linalg.norm(B[:, 1])
        return Plane(self.centroid, n, B, self.slope_cov)

    def intersect_rays(self, points: np.ndarray) -> np.ndarray:
        """Where the rays from the origin (the camera centre) through points (n, 3) meet it."""
        return points * ((self.centroid @ self.normal) / (points @ self.normal))[:, None]


def fit_plane(points: np.ndarray) -> Plane:
    """Total-least-squares plane through points (n, 3), with the covariance of its slopes.

    The slope covariance is that of a regression of the out-of-plane residuals on the in-plane
    coordinates, scaled by the residual variance. The normal's sign (its largest component
    positive) and the in-plane basis (the x axis projected, or y for a plane across x, then
    normal x that) are fixed by rule: the SVD's own signs and pair of in-plane vectors are
    LAPACK's free choice and differ between CPUs.
    """
    c = points.mean(axis=0)
    _, _, Vt = np.linalg.svd(points - c, full_matrices=False)
    n = Vt[2] * np.sign(Vt[2][np.argmax(np.abs(Vt[2]))])
    b0 = np.eye(3)[0 if abs(n[0]) < 0.9 else 1]
    b0 = b0 - n * (n @ b0)
    b0 /= np.linalg.norm(b0)
    B = np.stack([b0, np.cross(n, b0)], axis=1)
    xy = (points - c) @ B
    d = (points - c) @ n
    dof = max(len(points) - 3, 1)
    return Plane(c, n, B, np.linalg.inv(xy.T @ xy) * (d @ d) / dof)
