"""Zhang's camera calibration from several views of a planar target, with standard deviations.

Intrinsics K = [[fx, 0, cx], [0, fy, cy], [0, 0, 1]] in pixels; distortion in OpenCV's order
(k1, k2, p1, p2, k3). The standard deviations are OpenCV's: the square roots of the diagonal
of (J^T J)^-1 scaled by the residual variance, i.e. they assume independent corner noise.
"""

from __future__ import annotations

import dataclasses

import cv2
import numpy as np

INTRINSIC_NAMES = ("fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3")


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
    cov: np.ndarray | None = None  # of the estimated intrinsics cov_names (k, k), the views' poses eliminated
    cov_names: tuple[str, ...] = ()

    def params(self) -> dict[str, float]:
        """The intrinsics by name (fx, fy, cx, cy px; k1, k2, p1, p2, k3)."""
        K, d = self.K, self.dist
        return dict(zip(INTRINSIC_NAMES, [K[0, 0], K[1, 1], K[0, 2], K[1, 2], *d[:5]]))


def calibrate_camera(object_points: np.ndarray, image_points: list[np.ndarray],
                     image_size: tuple[int, int], fix_aspect: bool = False,
                     fix_k3: bool = True, tangential: bool = True) -> CameraCalibration:
    """Calibrate from views of one planar target.

    Parameters
    ----------
    object_points : (n_corners, 3) target points (z = 0) in the target's unit.
    image_points : list of (n_corners, 2) detected corners, one per view; a NaN row is a corner
        left out of that view (e.g. a gross detection error).
    image_size : (width, height) in pixels.
    fix_aspect : keep fx / fy at the initial guess's ratio (1).
    fix_k3, tangential : which distortion terms are estimated.
    """
    n_views = len(image_points)
    if n_views < 3:
        raise CalibrationError(f"{n_views} usable views: a calibration needs at least 3")
    obj = np.asarray(object_points, np.float32)
    if obj.ndim != 2 or obj.shape[1] != 3 or np.any(obj[:, 2] != 0):
        raise CalibrationError("object points must be (n, 3) on the plane z = 0")
    imgs = [np.asarray(p, np.float32).reshape(-1, 1, 2) for p in image_points]
    for p in imgs:
        if p.shape[0] != obj.shape[0] or np.isinf(p).any():
            raise CalibrationError("every view needs one image point (or NaN: left out) per target point")
    # each view with the corners it kept
    keep = [np.isfinite(p).all(axis=(1, 2)) for p in imgs]
    if min(k.sum() for k in keep) < 6:
        raise CalibrationError("a view keeps fewer than 6 corners")
    objs = [obj[k] for k in keep]
    imgs = [p[k] for p, k in zip(imgs, keep)]
    _check_not_degenerate(objs, imgs, image_size)
    flags = 0
    if fix_aspect:
        flags |= cv2.CALIB_FIX_ASPECT_RATIO
    if fix_k3:
        flags |= cv2.CALIB_FIX_K3
    if not tangential:
        flags |= cv2.CALIB_ZERO_TANGENT_DIST
    K0 = None
    if fix_aspect:
        K0 = cv2.initCameraMatrix2D(objs, imgs, image_size, 1.0)
        K0[1, 1] = K0[0, 0]
    crit = (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 200, 1e-12)
    # calibrateCamera, not ...Extended: the std come from our Schur-complement covariance (equal
    # to OpenCV's to 5 digits), which skips the extrinsics' block and takes a sixth of the time
    rms, K, dist, rvecs, tvecs = cv2.calibrateCamera(objs, imgs, image_size, K0, None, flags=flags, criteria=crit)
    dist = np.zeros(5) if dist is None else np.asarray(dist, float).ravel()[:5]
    K = np.asarray(K, float)
    rvecs, tvecs = np.asarray(rvecs, float).reshape(-1, 3), np.asarray(tvecs, float).reshape(-1, 3)
    estimated = {"fx", "fy", "cx", "cy", "k1", "k2"}
    if tangential:
        estimated |= {"p1", "p2"}
    if not fix_k3:
        estimated.add("k3")
    calib = CameraCalibration(K=K, dist=dist, std={}, rms_px=float(rms), per_view_rms_px=np.zeros(len(rvecs)),
                              rvecs=rvecs, tvecs=tvecs, image_size=tuple(image_size))
    # under a fixed aspect ratio fx and fy are one parameter (fy = a fx): its std from the
    # information with both columns combined (OpenCV would report std(fx) = 0)
    names = tuple(n for n in INTRINSIC_NAMES if n in estimated and not (fix_aspect and n == "fy"))
    views = _reprojections(calib, obj, [np.asarray(p, float).reshape(-1, 2) for p in image_points])
    cov = intrinsic_covariance(calib, obj, None, names, fix_aspect=fix_aspect, _views=views)
    std = {n: float(np.sqrt(cov[i, i])) for i, n in enumerate(names)}
    if fix_aspect:
        std["fy"] = std["fx"] * float(K[1, 1] / K[0, 0])
    per_view = np.sqrt(np.nanmean(np.sum(views[0] ** 2, axis=2), axis=1))  # over the corners each view kept
    return dataclasses.replace(calib, std={n: std[n] for n in INTRINSIC_NAMES if n in std}, cov=cov, cov_names=names,
                               per_view_rms_px=per_view)


def _check_not_degenerate(objs: list[np.ndarray], imgs: list[np.ndarray], image_size) -> None:
    """Zhang's constraints vanish when every view is parallel to the image plane.

    With H = K [r1 r2 t] / t_z, the tilt of a view is about |H[2, :2]| * f / sqrt(det H[:2, :2]);
    f is taken as the image width (a rough focal length is enough to tell 0 from 0.1 rad).
    """
    for obj, p in zip(objs, imgs):
        H, _ = cv2.findHomography(obj[:, :2], p.reshape(-1, 2), 0)
        if H is None:
            raise CalibrationError("a view's corners are collinear: no homography")
        H = H / H[2, 2]
        scale = np.sqrt(abs(np.linalg.det(H[:2, :2])))
        if np.linalg.norm(H[2, :2]) * max(image_size) / scale >= 0.02:
            return  # one tilted view is enough
    raise CalibrationError("degenerate pose set: all views are parallel to the image plane, "
                           "tilt the target between views")


def _reprojections(calib: CameraCalibration, object_points: np.ndarray,
                   image_points: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Each view's residuals, detected minus projected, (n_views, n_corners, 2) px (NaN where a
    corner was left out), and OpenCV's Jacobian of its kept corners' projections, zero-padded,
    (n_views, 2 n_corners, 15): rvec, tvec, fx, fy, cx, cy, k1, k2, p1, p2, k3."""
    obj = np.asarray(object_points, np.float64)
    n_views = len(calib.rvecs)
    J = np.zeros((n_views, 2 * len(obj), 15))
    res = np.full((n_views, len(obj), 2), np.nan)
    for v, (rvec, tvec, pts) in enumerate(zip(calib.rvecs, calib.tvecs, image_points)):
        pts = np.asarray(pts, float).reshape(-1, 2)
        kept = np.isfinite(pts).all(axis=1)  # NaN rows: corners left out of the view
        proj, jac = cv2.projectPoints(obj[kept], rvec, tvec, calib.K, calib.dist)
        res[v, kept] = pts[kept] - proj.reshape(-1, 2)
        J[v, :len(jac)] = jac[:, :15]
    return res, J


def intrinsic_covariance(calib: CameraCalibration, object_points: np.ndarray,
                         image_points: list[np.ndarray] | None, names: tuple[str, ...],
                         fix_aspect: bool = False, _views=None) -> np.ndarray:
    """Full covariance of the estimated intrinsics ``names``, shape (k, k).

    Gauss-Newton information of all views, with each view's pose eliminated (Schur complement),
    scaled by the residual variance as OpenCV does for its standard deviations. With
    ``fix_aspect`` fx and fy are one parameter (fy = a fx): name it "fx" and omit "fy".
    ``_views``: the views' :func:`_reprojections`, when the caller has them.
    """
    cols = {n: i for i, n in enumerate(("fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2", "k3"))}
    res, J = _reprojections(calib, object_points, image_points) if _views is None else _views
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
