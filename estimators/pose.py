"""Pose of a planar target in the camera frame (``board2cam``): closed form and refined.

``board2cam`` maps board-frame points X (mm, z = 0 on the target) to the OpenCV camera frame:
``x_cam = R @ X + t``. Rotations are (3, 3), translations (3,) in the board's unit.
"""

from __future__ import annotations

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
    nearest rotation (SVD) replaces the noisy [r1 r2 r3].
    """
    A = np.linalg.solve(K, H)
    lam = 1.0 / np.linalg.norm(A[:, 0])
    if A[2, 2] * lam < 0:
        lam = -lam
    r1, r2, t = lam * A[:, 0], lam * A[:, 1], lam * A[:, 2]
    U, _, Vt = np.linalg.svd(np.column_stack([r1, r2, np.cross(r1, r2)]))
    R = U @ np.diag([1, 1, np.linalg.det(U @ Vt)]) @ Vt
    return R, t


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


def mean_rotation(R: np.ndarray) -> np.ndarray:
    """Chordal L2 mean of rotations, (n, 3, 3) -> (3, 3)."""
    U, _, Vt = np.linalg.svd(np.sum(R, axis=0))
    return U @ np.diag([1, 1, np.linalg.det(U @ Vt)]) @ Vt


def translations_given_rotation(R: np.ndarray, board_points: np.ndarray, normalized: np.ndarray,
                                t0: np.ndarray, plane: tuple[np.ndarray, np.ndarray] | None = None,
                                iterations: int = 10) -> tuple[np.ndarray, np.ndarray]:
    """Per-view translations for views that share one rotation (a target that only translates).

    Gauss-Newton on the normalised image residuals of all views at once, analytic Jacobian.
    With ``plane`` the translations are confined to a plane (the carriage's plane of motion):
    t = origin + basis @ s, two unknowns per view instead of three, which removes each view's
    depth noise from its lateral position.

    Parameters
    ----------
    R : (3, 3) the common board2cam rotation.
    board_points : (n_points, 3) target points.
    normalized : (n_views, n_points, 2) ideal normalised image coordinates (K^-1, undistorted).
    t0 : (n_views, 3) starting translations.
    plane : (origin (3,), basis (3, 2)) or None.

    Returns
    -------
    t : (n_views, 3) translations.  cov : (n_views, 3, 3) their covariances, scaled by each
    view's residual variance (rank 2 on a plane).
    """
    P = board_points @ R.T  # (n_points, 3)
    if plane is None:
        origin, B = np.zeros(3), np.eye(3)
    else:
        origin, B = np.asarray(plane[0], float), np.asarray(plane[1], float)
    s = (np.asarray(t0, float) - origin) @ B  # least-squares start on the plane (B orthonormal)
    v, k = s.shape
    for _ in range(iterations):
        X = P[None] + (origin + s @ B.T)[:, None, :]  # (v, n, 3)
        z = X[..., 2]
        r = normalized - X[..., :2] / z[..., None]  # (v, n, 2)
        # d(x/z)/dt = [1/z, 0, -x/z^2], d(y/z)/dt = [0, 1/z, -y/z^2]
        Jt = np.zeros(r.shape + (3,))
        Jt[..., 0, 0] = 1 / z
        Jt[..., 1, 1] = 1 / z
        Jt[..., 0, 2] = -X[..., 0] / z**2
        Jt[..., 1, 2] = -X[..., 1] / z**2
        J = (Jt @ B).reshape(v, -1, k)
        r = r.reshape(v, -1)
        JtJ = np.einsum("vki,vkj->vij", J, J)
        step = np.linalg.solve(JtJ, np.einsum("vki,vk->vi", J, r)[..., None])[..., 0]
        s += step
        if np.max(np.abs(step)) < 1e-13 * (1 + np.max(np.abs(s))):
            break
    dof = max(r.shape[1] - k, 1)
    s2 = np.sum(r**2, axis=1) / dof
    cov_s = np.linalg.inv(JtJ) * s2[:, None, None]
    return origin + s @ B.T, B @ cov_s @ B.T


def fit_plane(points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Least-squares plane through points (n, 3): centroid (3,), unit normal (3,), basis (3, 2)."""
    c = points.mean(axis=0)
    _, _, Vt = np.linalg.svd(points - c, full_matrices=False)
    return c, Vt[2], Vt[:2].T
