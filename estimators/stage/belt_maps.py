"""The belt stage's error maps from station views of a board on the carriage (the seed's steps 2-4).

Each station's board2cam pose comes from the homography's closed form (Eq. 13-18), refined by
PnP; the board's centroid is tracked on the plane of motion fitted through all stations; travel
= displacement from the home station, error = travel - commanded travel; one bivariate quadratic
map per axis (Eq. 1). :func:`propagated_std` carries the intrinsics' covariance and the plane's
into the maps' standard deviations.

How the rig is seen (the seed's mounting, ``scenes.belt_stage``): the camera's image x runs along
+X and its image y along -Y; the board's x along +X and its y along -Y.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy.spatial.transform import Rotation

from calibench.estimators.camera.pose import (
    Plane,
    board2cam_from_homography,
    board2cam_refine,
    fit_plane,
    homographies,
    mean_rotation,
    pose_sensitivity,
    undistort_pixels,
)
from calibench.estimators.camera.zhang import CameraCalibration, intrinsic_covariance
from calibench.estimators.stage.compensation import design
from calibench.estimators.stage.error_map import QuadraticFit, fit_quadratic, quadratic_coefs
from calibench.estimators.stage.travel import board_yaw, travel_from_camera_centres, travel_in_plane

X_AXIS_CAM = np.array([1.0, 0.0, 0.0])  # the X motion in the camera frame
Y_AXIS_CAM = np.array([0.0, -1.0, 0.0])  # the Y motion in the camera frame
BOARD_XY_TO_AXES = np.diag([1.0, -1.0])  # board x, y onto machine X, Y
# the intrinsics whose covariance :func:`propagated_std` carries into the maps
MAP_INTRINSICS = ("fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2")


@dataclasses.dataclass
class StationPoses:
    """Per-station board2cam poses: closed form (from H) and PnP; R (n, 3, 3), t (n, 3) mm."""

    R_closed: np.ndarray
    t_closed: np.ndarray
    R_pnp: np.ndarray
    t_pnp: np.ndarray

    def in_plane_gap_mm(self) -> np.ndarray:
        """Each station's gap between its closed-form and its PnP position, in the board's plane.

        Returns
        -------
        (n,) mm: the closed form's depth is noisier and does not enter the travel, so only the
        board's x, y components count.
        """
        gap = np.einsum("nij,ni->nj", self.R_pnp[:, :, :2], self.t_closed - self.t_pnp)
        return np.linalg.norm(gap, axis=1)


@dataclasses.dataclass
class StageMaps:
    """Everything measured from the station views for one set of intrinsics."""

    poses: StationPoses
    plane: Plane  # plane of motion of the board's centroid, camera frame, mm
    travel: np.ndarray  # (n, 2) mm, ours
    err: np.ndarray  # (n, 2) mm, travel - pulse travel
    yaw_rad: float
    yaw_std_rad: float  # from the spread of the per-station yaws
    fit_x: QuadraticFit
    fit_y: QuadraticFit
    paper_fit_x: QuadraticFit | None  # None when not asked for
    paper_fit_y: QuadraticFit | None

    def vector(self) -> np.ndarray:
        """The 13 reported figures as one vector: ex c0..c5, ey c0..c5, yaw."""
        return np.r_[self.fit_x.coef, self.fit_y.coef, self.yaw_rad]


def measure_maps(
    board_pts: np.ndarray,
    corners_px: np.ndarray,
    K: np.ndarray,
    dist: np.ndarray,
    cmd: np.ndarray,
    ref: int,
    slopes: np.ndarray | None = None,
) -> StageMaps:
    """Stations' corners (n, n_corners, 2) and commands (n, 2) mm to the two error maps.

    The tracked point is the board's centroid, where a pose's tilt and translation errors
    decouple (the tilt of a small board seen from far is poorly determined). Each station's
    depth is noisy (~0.2 mm here); the carriage moves in a plane, so every centroid is moved
    along its viewing ray onto the plane fitted through all of them.

    Parameters
    ----------
    board_pts : (n_corners, 3) the board's corners in its own frame, mm (z = 0).
    corners_px : (n, n_corners, 2) each station's detected corners, px.
    K, dist : (3, 3) camera matrix and (5,) distortion (OpenCV's order).
    cmd : (n, 2) each station's commanded X, Y, mm.
    ref : the home station's index: travel and errors are measured from it.
    slopes : (2,) tilts the plane of motion (for propagating its uncertainty); None: as fitted.
    """
    return maps_from_poses(
        station_poses(board_pts, corners_px, K, dist), board_pts, cmd, ref, slopes
    )


def maps_from_poses(
    st: StationPoses,
    board_pts: np.ndarray,
    cmd: np.ndarray,
    ref: int,
    slopes: np.ndarray | None = None,
    paper: bool = True,
) -> StageMaps:
    """:func:`measure_maps` from the stations' poses on: plane, travel, errors, maps (``paper``:
    the seed paper's maps too, else None)."""
    plane, travel, err, yaw = _travel_errors(st, board_pts, cmd, ref, slopes)
    yaws = np.asarray(board_yaw(st.R_pnp, plane.normal, X_AXIS_CAM, Y_AXIS_CAM, BOARD_XY_TO_AXES))
    rel = cmd - cmd[ref]
    x, y = cmd[:, 0], cmd[:, 1]
    paper_x = paper_y = None
    if paper:
        err_paper = (
            travel_from_camera_centres(st.R_closed, st.t_closed, ref, BOARD_XY_TO_AXES) - rel
        )
        paper_x, paper_y = (
            fit_quadratic(x, y, err_paper[:, 0]),
            fit_quadratic(x, y, err_paper[:, 1]),
        )
    return StageMaps(
        poses=st,
        plane=plane,
        travel=travel,
        err=err,
        yaw_rad=yaw,
        yaw_std_rad=float(np.std(yaws, ddof=1) / np.sqrt(len(yaws))),
        fit_x=fit_quadratic(x, y, err[:, 0]),
        fit_y=fit_quadratic(x, y, err[:, 1]),
        paper_fit_x=paper_x,
        paper_fit_y=paper_y,
    )


def _travel_errors(
    st: StationPoses,
    board_pts: np.ndarray,
    cmd: np.ndarray,
    ref: int,
    slopes: np.ndarray | None = None,
) -> tuple[Plane, np.ndarray, np.ndarray, float]:
    """The plane of motion, each station's travel and error (n, 2) mm, and the board's yaw."""
    centroid = board_pts.mean(axis=0)
    p = np.einsum("nij,j->ni", st.R_pnp, centroid) + st.t_pnp
    plane = fit_plane(p)
    if slopes is not None:
        plane = plane.tilted(slopes)
    travel = travel_in_plane(plane.intersect_rays(p), ref, plane.normal, X_AXIS_CAM, Y_AXIS_CAM)
    R_mean = mean_rotation(st.R_pnp)
    yaw = float(board_yaw(R_mean, plane.normal, X_AXIS_CAM, Y_AXIS_CAM, BOARD_XY_TO_AXES))
    return plane, travel, travel - (cmd - cmd[ref]), yaw


def intrinsics_cov(
    calib: CameraCalibration,
    board_pts: np.ndarray,
    image_points: list[np.ndarray],
    names: tuple[str, ...] = MAP_INTRINSICS,
) -> np.ndarray:
    """The covariance of the intrinsics ``names`` that :func:`propagated_std` carries into the maps.

    Parameters
    ----------
    calib : the camera's calibration; its own covariance when it estimated exactly ``names``.
    board_pts : (n_corners, 3) the board's corners, mm.
    image_points : the calibration's views, each (n_corners, 2) px.
    names : the intrinsics, in :data:`MAP_INTRINSICS`' order.

    Returns
    -------
    (k, k) in the intrinsics' units (px, 1).
    """
    if calib.cov is not None and calib.cov_names == names:
        return calib.cov
    return intrinsic_covariance(calib, board_pts, image_points, names)


def propagated_std(
    m: StageMaps,
    board_pts: np.ndarray,
    K: np.ndarray,
    dist: np.ndarray,
    cmd: np.ndarray,
    ref: int,
    names: tuple[str, ...],
    cov_intr: np.ndarray,
) -> np.ndarray:
    """1-sigma of (ex c0..c5, ey c0..c5, yaw), (13,): the diagonal of :func:`propagated_cov`."""
    cov = propagated_cov(m, board_pts, K, dist, cmd, ref, names, cov_intr)
    return np.sqrt(np.diag(cov))


def propagated_cov(
    m: StageMaps,
    board_pts: np.ndarray,
    K: np.ndarray,
    dist: np.ndarray,
    cmd: np.ndarray,
    ref: int,
    names: tuple[str, ...],
    cov_intr: np.ndarray,
) -> np.ndarray:
    """Covariance of (ex c0..c5, ey c0..c5, yaw): station noise plus two common-mode errors.

    The intrinsics and the plane of motion are shared by every station, so their errors move
    the whole map coherently. Their effect is the Jacobian of the map coefficients with
    respect to them sandwiched around their covariance: each station's PnP pose moves with the
    intrinsics by the implicit-function Jacobian at its minimum (:func:`pose_sensitivity`, no PnP
    rerun), and the closed-form rest of the pipeline (plane, travel, maps) is differenced
    centrally at one sigma.

    Parameters
    ----------
    m : the maps (:func:`measure_maps`).
    board_pts : (n_corners, 3) the board's corners, mm.
    K, dist : (3, 3) and (5,) the intrinsics the maps were measured with.
    cmd : (n, 2) the stations' commands, mm; ``ref`` the home station.
    names : the k intrinsics of ``cov_intr`` (:data:`MAP_INTRINSICS`).
    cov_intr : (k, k) their covariance (:func:`intrinsics_cov`).

    Returns
    -------
    (13, 13) in mm, mm/mm, mm/mm^2 and rad, squared and crossed: each map's own part with its
    least-squares design's correlation, the common modes' with theirs (a focal length's error
    moves both maps' slopes at once, which the diagonal alone does not say).
    """
    st = m.poses
    S = pose_sensitivity(board_pts, st.R_pnp, st.t_pnp, K, dist, names)
    rvecs = Rotation.from_matrix(st.R_pnp).as_rotvec()

    def at(d_intr=None, slopes=None) -> np.ndarray:
        """The stations' errors and the yaw, (2 n + 1,), with the intrinsics or the plane moved."""
        poses = st
        if d_intr is not None:
            d = S @ d_intr  # (n, 6): each station's (rvec, t) moved
            poses = dataclasses.replace(
                st,
                R_pnp=Rotation.from_rotvec(rvecs + d[:, :3]).as_matrix(),
                t_pnp=st.t_pnp + d[:, 3:],
            )
        _, _, err, yaw = _travel_errors(poses, board_pts, cmd, ref, slopes)
        return np.r_[err[:, 0], err[:, 1], yaw]

    # central differences of the errors; the maps are linear in them: all fitted in one solve
    cols = []
    for j in range(len(names)):
        h = np.zeros(len(names))
        h[j] = np.sqrt(cov_intr[j, j])
        cols.append((at(h) - at(-h)) / (2 * h[j]))
    for j in range(2):
        h = np.zeros(2)
        h[j] = np.sqrt(m.plane.slope_cov[j, j])
        cols.append((at(slopes=h) - at(slopes=-h)) / (2 * h[j]))
    D = np.stack(cols, axis=1)  # (2 n + 1, k)
    n = len(cmd)
    x, y = cmd[:, 0], cmd[:, 1]
    coef = quadratic_coefs(x, y, np.concatenate([D[:n], D[n : 2 * n]], axis=1))  # (6, 2 k)
    k = D.shape[1]
    JJ = np.concatenate([coef[:, :k], coef[:, k:], D[2 * n :]], axis=0)  # (13, k)
    J, Js = JJ[:, : len(names)], JJ[:, len(names) :]
    # each map's own: its coefficients' std with the design's correlation (one design, both maps)
    inv = np.linalg.pinv(design(x, y, 2).T @ design(x, y, 2))
    corr = inv / np.sqrt(np.outer(np.diag(inv), np.diag(inv)))
    own = np.zeros((13, 13))
    for a, fit in enumerate((m.fit_x, m.fit_y)):
        own[6 * a : 6 * a + 6, 6 * a : 6 * a + 6] = corr * np.outer(fit.std, fit.std)
        # errors are measured from the home station, whose own scatter (the per-station RMSE)
        # moves every error alike: a common offset the residuals cannot show, c0's alone
        own[6 * a, 6 * a] += fit.rmse**2
    own[12, 12] = m.yaw_std_rad**2
    return own + J @ cov_intr @ J.T + Js @ m.plane.slope_cov @ Js.T


def station_poses(
    board_pts: np.ndarray, corners_px: np.ndarray, K: np.ndarray, dist: np.ndarray
) -> StationPoses:
    """Closed-form and PnP board2cam poses of every station, (n_stations, n_corners, 2) in."""
    ideal = undistort_pixels(np.asarray(corners_px, float).reshape(-1, 2), K, dist).reshape(
        np.shape(corners_px)
    )
    R0, t0 = board2cam_from_homography(homographies(board_pts[:, :2], ideal), K)
    R, t = board2cam_refine(board_pts, corners_px, K, dist, R0, t0)
    return StationPoses(R0, t0, R, t)
