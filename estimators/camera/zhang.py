"""Zhang's camera calibration from several views of a planar target, with standard deviations.

Intrinsics K = [[fx, 0, cx], [0, fy, cy], [0, 0, 1]] in pixels; distortion in OpenCV's order
(k1, k2, p1, p2, k3). The fit is OpenCV's ``calibrateCamera``'s (the same model, the same
maximum-likelihood estimate), solved here with each view's pose eliminated from the normal
equations. The standard deviations are OpenCV's: the square roots of the diagonal of
(J^T J)^-1 scaled by the residual variance, i.e. they assume independent corner noise.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from calibench.estimators.camera.pose import board2cam_from_homography, homographies
from calibench.estimators.camera.projection import INTRINSICS, project
from calibench.estimators.rotations import matrices_to_rotvecs_scipy, rotvecs_to_matrices_scipy

INTRINSIC_NAMES = INTRINSICS  # fx, fy, cx, cy, k1, k2, p1, p2, k3


class CalibrationError(ValueError):
    """The views cannot determine the camera (too few, or degenerate)."""


@dataclasses.dataclass(frozen=True)
class CameraCalibration:
    """Result of :func:`calibrate_camera`.

    K : (3, 3) camera matrix.  dist : (5,) k1, k2, p1, p2, k3.
    std : 1-sigma of each estimated parameter by name (fixed ones absent).
    rms_px : RMS reprojection error over all corners.  per_view_rms_px : (n_views,).
    rvecs, tvecs : (n_views, 3) board-to-camera poses (Rodrigues, and translation in the
    target's unit).
    cov, cov_names : the covariance of the estimated intrinsics (:func:`intrinsic_covariance`)
    and their names, in its order (under a fixed aspect ratio "fy" is not among them).
    """

    K: np.ndarray
    dist: np.ndarray
    std: dict[str, float]
    rms_px: float
    per_view_rms_px: np.ndarray
    rvecs: np.ndarray
    tvecs: np.ndarray
    image_size: tuple[int, int]
    cov: np.ndarray | None = (
        None  # of the estimated intrinsics cov_names (k, k), the views' poses eliminated
    )
    cov_names: tuple[str, ...] = ()

    def params(self) -> dict[str, float]:
        """The intrinsics by name (fx, fy, cx, cy px; k1, k2, p1, p2, k3)."""
        K, d = self.K, self.dist
        return dict(zip(INTRINSIC_NAMES, [K[0, 0], K[1, 1], K[0, 2], K[1, 2], *d[:5]]))


def calibrate_camera(
    object_points: np.ndarray,
    image_points: list[np.ndarray],
    image_size: tuple[int, int],
    fix_aspect: bool = False,
    fix_k3: bool = True,
    tangential: bool = True,
) -> CameraCalibration:
    """Calibrate from views of one planar target.

    Zhang's closed form from the views' homographies (principal point at the image's centre,
    no distortion), then a bundle adjustment of the intrinsics and every view's pose: the
    maximum-likelihood fit OpenCV's ``calibrateCamera`` makes, solved with each view's pose
    eliminated (Schur complement) so an iteration costs the same at 10 views or 200.

    Parameters
    ----------
    object_points : (n_corners, 3) target points (z = 0) in the target's unit.
    image_points : list of (n_corners, 2) detected corners, one per view; a NaN row is a corner
        left out of that view (e.g. a gross detection error).
    image_size : (width, height) in pixels.
    fix_aspect : keep fx / fy at 1.
    fix_k3, tangential : which distortion terms are estimated.
    """
    n_views = len(image_points)
    if n_views < 3:
        raise CalibrationError(f"{n_views} usable views: a calibration needs at least 3")
    obj = np.asarray(object_points, float)
    if obj.ndim != 2 or obj.shape[1] != 3 or np.any(obj[:, 2] != 0):
        raise CalibrationError("object points must be (n, 3) on the plane z = 0")
    given = [np.asarray(p, float) for p in image_points]
    if any(p.shape != (len(obj), 2) or np.isinf(p).any() for p in given):
        raise CalibrationError(
            "every view needs one image point (or NaN: left out) per target point"
        )
    # points rounded to float32 as OpenCV's calibrateCamera takes them, so every result stays
    # that of the OpenCV-based calibration this replaces (equal to 1e-11 px): a 640 px
    # coordinate moves by at most 3e-5 px, under 0.3 % of the 0.01 px corners' noise
    obj = obj.astype(np.float32).astype(float)
    measured = np.stack(given)
    pixels = measured.astype(np.float32).astype(float)
    kept = np.isfinite(pixels).all(axis=2)  # (n_views, n_corners)
    if kept.sum(axis=1).min() < 6:
        raise CalibrationError("a view keeps fewer than 6 corners")
    try:
        H = homographies(obj[:, :2], pixels)
    except ValueError as e:
        raise CalibrationError(str(e)) from None
    _check_not_degenerate(H, image_size)
    estimated = (
        {"fx", "fy", "cx", "cy", "k1", "k2"}
        | ({"p1", "p2"} if tangential else set())
        | (set() if fix_k3 else {"k3"})
    )
    # under a fixed aspect ratio fx and fy are one parameter, named fx (fy = fx)
    names = tuple(n for n in INTRINSIC_NAMES if n in estimated and not (fix_aspect and n == "fy"))
    start = _initial_intrinsics(H, image_size, fix_aspect)
    R0, t0 = board2cam_from_homography(H, _camera_matrix(start))
    fit = _bundle_adjust(obj, pixels, start, R0, t0, names, fix_aspect)
    if not fit.converged:
        raise CalibrationError(f"the calibration did not converge in {fit.iterations} iterations")
    views = _reprojections(fit.intrinsics, fit.R, fit.t, obj, measured)  # the corners as measured
    r = views[0][kept]
    calib = CameraCalibration(
        K=_camera_matrix(fit.intrinsics),
        dist=fit.intrinsics[[4, 5, 6, 7, 8]].copy(),
        std={},
        rms_px=float(np.sqrt(np.sum(r**2) / len(r))),
        per_view_rms_px=np.sqrt(
            np.nanmean(np.sum(views[0] ** 2, axis=2), axis=1)
        ),  # over each view's kept corners
        rvecs=matrices_to_rotvecs_scipy(fit.R),
        tvecs=fit.t,
        image_size=(image_size[0], image_size[1]),
    )
    cov = intrinsic_covariance(calib, obj, None, names, fix_aspect=fix_aspect, _views=views)
    std = {n: float(np.sqrt(cov[i, i])) for i, n in enumerate(names)}
    if fix_aspect:
        std["fy"] = std["fx"]  # fy = fx: the same parameter (OpenCV would report std(fx) = 0)
    return dataclasses.replace(
        calib, std={n: std[n] for n in INTRINSIC_NAMES if n in std}, cov=cov, cov_names=names
    )


def _check_not_degenerate(H: np.ndarray, image_size) -> None:
    """Zhang's constraints vanish when every view is parallel to the image plane.

    With H = K [r1 r2 t] / t_z, the tilt of a view is about |H[2, :2]| * f / sqrt(det H[:2, :2]);
    f is taken as the image width (a rough focal length is enough to tell 0 from 0.1 rad).
    """
    scale = np.sqrt(np.abs(np.linalg.det(H[:, :2, :2])))
    if not np.any(np.linalg.norm(H[:, 2, :2], axis=1) * max(image_size) / scale >= 0.02):
        raise CalibrationError(
            "degenerate pose set: all views are parallel to the image plane, "
            "tilt the target between views"
        )


def _camera_matrix(intrinsics: np.ndarray) -> np.ndarray:
    """K (3, 3) from intrinsics (9,) in ``INTRINSIC_NAMES`` order."""
    fx, fy, cx, cy = intrinsics[:4]
    return np.array([[fx, 0.0, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]])


def _initial_intrinsics(H: np.ndarray, image_size, fix_aspect: bool) -> np.ndarray:
    """Focal lengths from Zhang's two constraints per view, the principal point at the image's
    centre and no distortion (OpenCV's ``initCameraMatrix2D``): (9,) in ``INTRINSIC_NAMES`` order.

    With the principal point removed, r1 . r2 = 0 and |r1| = |r2| are linear in 1 / fx^2 and
    1 / fy^2 (the same unknown under ``fix_aspect``)."""
    cx, cy = (image_size[0] - 1) / 2, (image_size[1] - 1) / 2
    Hc = H.copy()
    Hc[:, 0] -= cx * H[:, 2]
    Hc[:, 1] -= cy * H[:, 2]
    h1, h2 = Hc[:, :, 0], Hc[:, :, 1]
    d1, d2 = h1 + h2, h1 - h2
    h1, h2 = (
        h1 / np.linalg.norm(h1, axis=1, keepdims=True),
        h2 / np.linalg.norm(h2, axis=1, keepdims=True),
    )
    d1, d2 = (
        d1 / np.linalg.norm(d1, axis=1, keepdims=True),
        d2 / np.linalg.norm(d2, axis=1, keepdims=True),
    )
    # rows: h1 . B h2 = 0 and d1 . B d2 = 0 (|h1| = |h2| after the 45-degree turn), B = diag(a, b,
    # 1)
    A = np.concatenate([h1[:, :2] * h2[:, :2], d1[:, :2] * d2[:, :2]])
    rhs = -np.concatenate([h1[:, 2] * h2[:, 2], d1[:, 2] * d2[:, 2]])
    if fix_aspect:
        a = np.linalg.lstsq(A.sum(axis=1, keepdims=True), rhs, rcond=None)[0][0]
        ab = np.array([a, a])
    else:
        ab = np.linalg.lstsq(A, rhs, rcond=None)[0]
    if np.any(ab <= 0):
        raise CalibrationError("the views do not determine a focal length: tilt the target more")
    fx, fy = 1 / np.sqrt(ab)
    return np.array([fx, fy, cx, cy, 0, 0, 0, 0, 0], float)


XTOL = 1e-8  # the bundle adjustment's last step, in units of each parameter's std
SIGMA_FLOOR_PX = 1e-3  # the residual's scale XTOL is taken of, at least


@dataclasses.dataclass(frozen=True)
class _Fit:
    intrinsics: np.ndarray  # (9,) INTRINSIC_NAMES order
    R: np.ndarray  # (n_views, 3, 3) board2cam
    t: np.ndarray  # (n_views, 3)
    iterations: int
    converged: bool


def _design(intrinsics, R, t, obj, pixels, kept, names, fix_aspect, jacobians=True):
    """Residuals detected - projected, (n_views, 2 n) with left-out corners at 0, and (if asked)
    their Jacobians with respect to the views' poses (n_views, 2 n, 6) and the free intrinsics
    ``names`` (n_views, 2 n, k)."""
    P = project(intrinsics, R, t, obj, jacobians=jacobians)
    n_views = len(R)
    w = np.repeat(kept, 2, axis=1).astype(float)
    r = np.where(w > 0, (pixels - P.uv).reshape(n_views, -1), 0.0)
    if not jacobians:
        return r, None, None
    Je = P.d_pose.reshape(n_views, -1, 6) * w[..., None]
    cols = [INTRINSIC_NAMES.index(n) for n in names]
    Ji = P.d_intrinsics.reshape(n_views, -1, 9)[..., cols] * w[..., None]
    if fix_aspect:  # fy = fx: one column for both
        Ji[..., names.index("fx")] += P.d_intrinsics.reshape(n_views, -1, 9)[..., 1] * w
    return r, Je, Ji


def _bundle_adjust(obj, pixels, intrinsics, R, t, names, fix_aspect, max_iter: int = 100) -> _Fit:
    """Levenberg-Marquardt over the free intrinsics ``names`` and each view's pose (a left
    rotation and a shift), the poses eliminated from each step's normal equations.

    Converged when a step moves no parameter by more than ``XTOL`` of its std, or when no
    damping finds a lower cost and the gradient vanishes. The tight ``XTOL`` keeps results to their
    last digits whatever the start: where a looser solver stops depends on where it began.

    Not on the identification core: each step eliminates the views' poses from the normal
    equations (a Schur complement, 6 x 6 per view), which the core's dense and sparse normal
    equations do not; which intrinsics are free is the caller's (``names``), not a basis's."""
    kept = np.isfinite(pixels).all(axis=2)
    pixels = np.where(kept[..., None], pixels, 0.0)
    cols = [INTRINSIC_NAMES.index(n) for n in names]
    x = np.asarray(intrinsics, float).copy()
    r, Je, Ji = _design(x, R, t, obj, pixels, kept, names, fix_aspect)
    cost = float(np.sum(r * r))
    n_res, n_params = 2 * int(kept.sum()), len(cols) + 6 * len(R)
    lam = 1e-3
    converged, it = False, 0
    for it in range(1, max_iter + 1):  # noqa: B007 - the count is reported after the loop
        Jv = np.concatenate([Je, Ji], axis=2)  # (v, 2 n, 6 + k)
        M = Jv.transpose(0, 2, 1) @ Jv  # each view's normal matrix
        g = (Jv.transpose(0, 2, 1) @ r[..., None])[..., 0]
        A, B, C = M[:, 6:, 6:].sum(axis=0), M[:, 6:, :6], M[:, :6, :6]
        gi, ge = g[:, 6:].sum(axis=0), g[:, :6]
        diag_i, diag_e = np.diag(A).copy(), np.diagonal(C, axis1=1, axis2=2).copy()
        while True:
            Cd = C + lam * diag_e[:, :, None] * np.eye(6)
            CinvBt = np.linalg.solve(
                Cd, np.concatenate([B.transpose(0, 2, 1), ge[..., None]], axis=2)
            )
            BCinv = B @ CinvBt  # (v, k, k + 1): B C^-1 B^T and B C^-1 g_e
            S = A + lam * np.diag(diag_i) - BCinv[..., :-1].sum(axis=0)
            di = np.linalg.solve(S, gi - BCinv[..., -1].sum(axis=0))
            de = CinvBt[..., -1] - CinvBt[..., :-1] @ di
            x_new = x.copy()
            x_new[cols] += di
            if fix_aspect:
                x_new[1] = x_new[0]
            R_new = rotvecs_to_matrices_scipy(de[:, :3]) @ R
            t_new = t + de[:, 3:]
            r_new, _, _ = _design(
                x_new, R_new, t_new, obj, pixels, kept, names, fix_aspect, jacobians=False
            )
            cost_new = float(np.sum(r_new * r_new))
            # the step in units of each parameter's (conditional) std; the residual's scale
            # floored at 1e-3 px: below it (corners without noise, their float32 rounding
            # 4e-5 px) XTOL of the std would ask for steps under float64's own rounding of the
            # pixel coordinates, and the solve would wander there for ever
            sigma = max(np.sqrt(cost / max(n_res - n_params, 1)), SIGMA_FLOOR_PX)
            size = (
                max(np.max(np.abs(di) * np.sqrt(diag_i)), np.max(np.abs(de) * np.sqrt(diag_e)))
                / sigma
            )
            small = size < XTOL
            # a step under 1e-3 std is taken whatever the cost says: the cost's own rounding (1e-12
            # of it, the residuals being differences of pixel coordinates) hides a change that small
            if cost_new < cost or size < 1e-3:
                x, R, t, cost, lam = x_new, R_new, t_new, cost_new, max(lam / 10, 1e-12)
                break
            if lam > 1e10:
                break
            lam *= 10
        if small:
            converged = True
            break
        if lam > 1e10:  # no damping lowers the cost: a minimum if the gradient vanishes there
            grad = np.r_[
                gi / np.sqrt(np.maximum(diag_i, 1e-300)),
                (ge / np.sqrt(np.maximum(diag_e, 1e-300))).ravel(),
            ]
            converged = bool(np.max(np.abs(grad)) < XTOL * max(np.sqrt(cost), 1e-9))
            break
        r, Je, Ji = _design(x, R, t, obj, pixels, kept, names, fix_aspect)
    return _Fit(x, R, t, it, converged)


def _state(calib: CameraCalibration) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A calibration's intrinsics (9,) in ``INTRINSIC_NAMES`` order and its views' board2cam
    R (n_views, 3, 3), t (n_views, 3)."""
    K = calib.K
    intrinsics = np.r_[K[0, 0], K[1, 1], K[0, 2], K[1, 2], np.r_[calib.dist, np.zeros(5)][:5]]
    return intrinsics, rotvecs_to_matrices_scipy(calib.rvecs), np.asarray(calib.tvecs, float)


def _reprojections(
    intrinsics: np.ndarray, R: np.ndarray, t: np.ndarray, object_points: np.ndarray, image_points
) -> tuple[np.ndarray, np.ndarray]:
    """Each view's residuals, detected minus projected, (n_views, n_corners, 2) px (NaN where a
    corner was left out), and the Jacobian of its kept corners' projections (zero rows for the
    others), (n_views, 2 n_corners, 15): the pose's left rotation and shift, then fx, fy, cx, cy,
    k1, k2, p1, p2, k3; for intrinsics (9,) and views R (n_views, 3, 3), t (n_views, 3)."""
    obj = np.asarray(object_points, float)
    pixels = np.stack([np.asarray(p, float).reshape(-1, 2) for p in image_points])
    P = project(intrinsics, R, t, obj)
    kept = np.isfinite(pixels).all(axis=2)
    res = np.where(kept[..., None], pixels - P.uv, np.nan)
    J = np.concatenate([P.d_pose, P.d_intrinsics], axis=3) * kept[..., None, None]
    return res, J.reshape(len(R), 2 * len(obj), 15)


def intrinsic_covariance(
    calib: CameraCalibration,
    object_points: np.ndarray,
    image_points: list[np.ndarray] | None,
    names: tuple[str, ...],
    fix_aspect: bool = False,
    _views=None,
) -> np.ndarray:
    """Full covariance of the estimated intrinsics ``names``, shape (k, k).

    Gauss-Newton information of all views, with each view's pose eliminated (Schur complement),
    scaled by the residual variance as OpenCV does for its standard deviations. With
    ``fix_aspect`` fx and fy are one parameter (fy = a fx): name it "fx" and omit "fy".
    ``_views``: the views' :func:`_reprojections`, when the caller has them.
    """
    cols = {n: i for i, n in enumerate(("fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3"))}
    res, J = (
        _reprojections(*_state(calib), object_points, image_points) if _views is None else _views
    )
    aspect = calib.K[1, 1] / calib.K[0, 0]
    r = res[np.isfinite(res)]
    sse, n_res = float(r @ r), r.size
    Je = J[:, :, :6]
    Ji = J[:, :, [6 + cols[n] for n in names]]
    if fix_aspect:
        Ji[:, :, names.index("fx")] += aspect * J[:, :, 6 + cols["fy"]]
    A, B, C = (np.einsum("vri,vrj->vij", P, Q) for P, Q in ((Ji, Ji), (Ji, Je), (Je, Je)))
    # each view's pose eliminated: A - B C^-1 B^T, summed over the views
    info = np.sum(A - B @ np.linalg.solve(C, B.transpose(0, 2, 1)), axis=0)
    n_params = len(names) + 6 * len(calib.rvecs)
    sigma2 = sse / max(n_res - n_params, 1)
    return np.linalg.inv(info) * sigma2
