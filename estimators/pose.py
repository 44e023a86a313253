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
    H, _ = cv2.findHomography(np.asarray(board_xy, np.float64), np.asarray(pixels, np.float64), 0)
    if H is None:
        raise ValueError("degenerate points: no homography")
    return H


def board2cam_from_homography(H: np.ndarray, K: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Closed-form extrinsics from H = s K [r1 r2 t] (Zhang; the seed paper's Eq. 13-18).

    lambda = 1 / |K^-1 h1|, r1 = lambda K^-1 h1, r2 = lambda K^-1 h2, r3 = r1 x r2,
    t = lambda K^-1 h3; the sign makes the target lie in front of the camera, and the
    nearest rotation (SVD) replaces the noisy [r1 r2 r3]. H (3, 3) gives R (3, 3), t (3,);
    a stack H (n, 3, 3) gives R (n, 3, 3), t (n, 3).
    """
    Hs = np.asarray(H, float)
    A = np.linalg.solve(K, Hs.reshape(-1, 3, 3).transpose(1, 0, 2).reshape(3, -1)).reshape(3, -1, 3).transpose(1, 0, 2)
    lam = 1.0 / np.linalg.norm(A[:, :, 0], axis=1)
    lam = np.where(A[:, 2, 2] * lam < 0, -lam, lam)[:, None]
    r1, r2, t = lam * A[:, :, 0], lam * A[:, :, 1], lam * A[:, :, 2]
    U, _, Vt = np.linalg.svd(np.stack([r1, r2, np.cross(r1, r2)], axis=2))
    D = np.ones((len(A), 3))
    D[:, 2] = np.linalg.det(U @ Vt)
    R = (U * D[:, None, :]) @ Vt
    return (R[0], t[0]) if Hs.ndim == 2 else (R, t)


def board2cam_pnp(board_points: np.ndarray, pixels: np.ndarray, K: np.ndarray, dist: np.ndarray,
                  guess: tuple[np.ndarray, np.ndarray] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Maximum-likelihood pose (Levenberg-Marquardt on reprojection error), R (3, 3), t (3,)."""
    obj = np.asarray(board_points, np.float64)
    img = np.asarray(pixels, np.float64)
    if guess is None:
        ok, rvec, tvec = cv2.solvePnP(obj, img, K, dist, flags=cv2.SOLVEPNP_ITERATIVE)
    else:
        rvec0 = cv2.Rodrigues(guess[0])[0]
        ok, rvec, tvec = cv2.solvePnP(obj, img, K, dist, rvec0, guess[1].reshape(3, 1).copy(),
                                      useExtrinsicGuess=True, flags=cv2.SOLVEPNP_ITERATIVE)
    if not ok:
        raise ValueError("PnP failed")
    return cv2.Rodrigues(rvec)[0], tvec.ravel()


# projectPoints' Jacobian columns after (rvec, tvec): fx, fy, cx, cy, then k1, k2, p1, p2, k3
_INTRINSIC_COLUMN = {"fx": 6, "fy": 7, "cx": 8, "cy": 9, "k1": 10, "k2": 11, "p1": 12, "p2": 13, "k3": 14}


def pose_sensitivity(board_points: np.ndarray, R: np.ndarray, t: np.ndarray, K: np.ndarray, dist: np.ndarray,
                     names: tuple[str, ...]) -> np.ndarray:
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
    jac = np.stack([cv2.projectPoints(obj, cv2.Rodrigues(Ri)[0], ti.reshape(3, 1), K, dist)[1] for Ri, ti in zip(R, t)])
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

    def tilted(self, slopes: np.ndarray) -> "Plane":
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
    coordinates, scaled by the residual variance.
    """
    c = points.mean(axis=0)
    _, _, Vt = np.linalg.svd(points - c, full_matrices=False)
    n, B = Vt[2], Vt[:2].T
    xy = (points - c) @ B
    d = (points - c) @ n
    dof = max(len(points) - 3, 1)
    return Plane(c, n, B, np.linalg.inv(xy.T @ xy) * (d @ d) / dof)
