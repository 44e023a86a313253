"""The belt stage's procedure as named steps, in the order ``run`` takes them: the tilted views of
the free board, the stations with Zhang's calibration, the two error maps, and the compensation
checked at points no fit saw. Each step takes the run's one ``numpy.random.Generator`` where it
draws, so that the steps in this order make the same draws as the procedure in one piece."""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING

import numpy as np

from calibench.errors import BadInput
from calibench.estimators.camera.zhang import CameraCalibration, calibrate_camera
from calibench.estimators.stage.belt_maps import (
    MAP_INTRINSICS,
    StageMaps,
    intrinsics_cov,
    measure_maps,
    propagated_std,
)
from calibench.estimators.stage.error_map import QuadraticFit, compensated_command
from calibench.recordings import CameraViews
from calibench.scenarios.belt_stage.views import record_views
from calibench.sim.belt_stage import PULSES_PER_MM, BeltStageSim, intrinsic_view_poses

if TYPE_CHECKING:  # the config's module imports this one
    from calibench.scenarios.belt_stage.scenario import BeltStageConfig


@dataclasses.dataclass
class Views:
    """Views of the board as the estimators get them, with the truth the scenario keeps.

    Attributes
    ----------
    views : CameraViews
        Names, images (where kept) and corners as recorded.
    corners_px : ndarray, (n_views, n_corners, 2)
        The detected corners (``views.corners_px``, never None here), NaN where undetected.
    true_px : ndarray, (n_views, n_corners, 2)
        The exact projections of the true corners.
    """

    views: CameraViews
    corners_px: np.ndarray
    true_px: np.ndarray


@dataclasses.dataclass
class IntrinsicViews(Views):
    """The tilted views of the free board (:class:`Views`), and which of them were detected.

    Attributes
    ----------
    used : ndarray of bool, (n_views,)
        The views whose every corner was detected: those the calibration takes.
    """

    used: np.ndarray


@dataclasses.dataclass
class StationViews(Views):
    """The carriage's stations (:class:`Views`, every corner detected) and their commands.

    Attributes
    ----------
    x_pulses, y_pulses : ndarray of int64, (n_stations,)
        Each station's commanded position, in pulses.
    ref : int
        The home station's index: travel and errors are measured from it.
    """

    x_pulses: np.ndarray
    y_pulses: np.ndarray
    ref: int

    @property
    def cmd_mm(self) -> np.ndarray:
        """(n_stations, 2) each station's commanded X, Y, mm."""
        return np.stack([self.x_pulses, self.y_pulses], axis=1) / PULSES_PER_MM


@dataclasses.dataclass
class Maps:
    """Both axes' error maps measured from the stations, with the intrinsics' uncertainty.

    Attributes
    ----------
    cmd : ndarray, (n_stations, 2)
        Each station's commanded X, Y, mm.
    maps : StageMaps
        Poses, travel, errors, the maps and the board's yaw
        (:func:`calibench.estimators.stage.belt_maps.measure_maps`).
    paper_fit_x, paper_fit_y : QuadraticFit
        The seed paper's maps (camera-centre differences, the board square to the axes).
    std : ndarray, (13,)
        1-sigma of ex c0..c5, ey c0..c5 and the yaw (rad): the fit's own with the intrinsics'
        covariance carried through.
    """

    cmd: np.ndarray
    maps: StageMaps
    paper_fit_x: QuadraticFit
    paper_fit_y: QuadraticFit
    std: np.ndarray


@dataclasses.dataclass
class Compensation:
    """The compensation checked at random points of the travel that no fit saw.

    Attributes
    ----------
    targets : ndarray, (n_check, 2)
        The positions wanted, mm.
    before : ndarray, (n_check, 2)
        True position minus target, the targets commanded as they are, mm.
    after : ndarray, (n_check, 2)
        The same with the commands compensated by the fitted maps, mm.
    """

    targets: np.ndarray
    before: np.ndarray
    after: np.ndarray


def intrinsic_views(
    sim: BeltStageSim,
    config: BeltStageConfig,
    fidelity: str,
    rng: np.random.Generator,
    windowed: bool,
    workers: int,
) -> IntrinsicViews:
    """Step 1: the free board in ``config.n_intrinsic_views`` tilted poses, then parked out of view.

    Parameters
    ----------
    sim : BeltStageSim
        The stage and its camera.
    config : BeltStageConfig
        The number of views, the board, the sensor's and the detector's noise.
    fidelity : str
        ``"render"`` or ``"analytic"``.
    rng : numpy.random.Generator
        Draws the poses, then each view's noise.
    windowed, workers
        As :func:`calibench.scenarios.belt_stage.views.record_views` takes them.

    Returns
    -------
    IntrinsicViews
        (n_views, n_corners, 2) corners and truth, and the (n_views,) views detected.
    """
    g = config.geometry
    size = (g.camera.width, g.camera.height)
    poses = intrinsic_view_poses(g, config.n_intrinsic_views, rng)
    views, true = record_views(
        sim, fidelity, config, rng, size, [("calib", R, t) for R, t in poses], windowed, workers
    )
    sim.park_calib_board()
    assert views.corners_px is not None  # record_views fills every view's corners (NaN if missed)
    used = np.isfinite(views.corners_px).all(axis=(1, 2))
    return IntrinsicViews(views, views.corners_px, true, used)


def station_grid(config: BeltStageConfig) -> tuple[np.ndarray, np.ndarray, int]:
    """The stations' commands: every X station with every Y station, rounded to pulses.

    Returns
    -------
    x_pulses, y_pulses : ndarray of int64, (n_y * n_x,)
        Row by row of the grid (Y outer, X inner).
    ref : int
        The home station's index.

    Raises
    ------
    BadInput
        When the grid holds the home station (0, 0) not exactly once.
    """
    xs, ys = np.meshgrid(config.stations_x_mm, config.stations_y_mm)
    x_pulses = np.rint(xs.ravel() * PULSES_PER_MM).astype(np.int64)
    y_pulses = np.rint(ys.ravel() * PULSES_PER_MM).astype(np.int64)
    home = np.flatnonzero((x_pulses == 0) & (y_pulses == 0))
    if len(home) != 1:
        raise BadInput("the station grid must contain the home station (0, 0) once")
    return x_pulses, y_pulses, int(home[0])


def station_views(
    sim: BeltStageSim,
    config: BeltStageConfig,
    fidelity: str,
    rng: np.random.Generator,
    windowed: bool,
    workers: int,
) -> StationViews:
    """Step 2: the board on the carriage, driven over the station grid (:func:`station_grid`).

    Parameters
    ----------
    sim, config, fidelity, windowed, workers
        As :func:`intrinsic_views` takes them.
    rng : numpy.random.Generator
        Draws each view's noise.

    Returns
    -------
    StationViews
        (n_stations, n_corners, 2) corners and truth, the stations' commands.

    Raises
    ------
    ValueError
        When the board was not detected at some station.
    """
    x_pulses, y_pulses, ref = station_grid(config)
    g = config.geometry
    size = (g.camera.width, g.camera.height)
    steps = [("station", xp, yp) for xp, yp in zip(x_pulses, y_pulses)]
    views, true = record_views(sim, fidelity, config, rng, size, steps, windowed, workers)
    assert views.corners_px is not None  # record_views fills every view's corners (NaN if missed)
    if not np.isfinite(views.corners_px).all():
        missed = [
            views.names[i] for i in np.flatnonzero(~np.isfinite(views.corners_px).all(axis=(1, 2)))
        ]
        raise ValueError(f"board not detected at station(s) {', '.join(missed[:5])}")
    return StationViews(views, views.corners_px, true, x_pulses, y_pulses, ref)


def calibration_points(intrinsic: IntrinsicViews, stations: StationViews) -> list[np.ndarray]:
    """The views Zhang's calibration takes, each (n_corners, 2) px: the tilted views detected, then
    the stations. Fronto-parallel, the stations say nothing of the focal length, but they sample
    the lens over the whole image."""
    return list(intrinsic.corners_px[intrinsic.used]) + list(stations.corners_px)


def calibrate(
    config: BeltStageConfig, board_pts: np.ndarray, calib_points: list[np.ndarray]
) -> CameraCalibration:
    """Step 2's calibration: Zhang's, k3 fixed, on ``calib_points`` (each (n_corners, 2) px) of the
    board's (n_corners, 3) corners, mm."""
    size = (config.geometry.camera.width, config.geometry.camera.height)
    return calibrate_camera(board_pts, calib_points, size, fix_k3=True)


def measure(
    board_pts: np.ndarray,
    stations: StationViews,
    calib: CameraCalibration,
    calib_points: list[np.ndarray],
) -> Maps:
    """Steps 3-4: the stations' poses, travel and errors, the two maps; then the intrinsics'
    uncertainty carried into them.

    Parameters
    ----------
    board_pts : ndarray, (n_corners, 3)
        The board's corners in its own frame, mm.
    stations : StationViews
        The stations' corners and commands.
    calib : CameraCalibration
        The camera the poses are measured with.
    calib_points : list of ndarray, each (n_corners, 2)
        The views the calibration took (their information is the intrinsics' covariance).

    Returns
    -------
    Maps
    """
    cmd, ref = stations.cmd_mm, stations.ref
    m = measure_maps(board_pts, stations.corners_px, calib.K, calib.dist, cmd, ref)
    cov_intr = intrinsics_cov(calib, board_pts, calib_points)
    std = propagated_std(m, board_pts, calib.K, calib.dist, cmd, ref, MAP_INTRINSICS, cov_intr)
    # measure_maps fits the seed paper's maps too (maps_from_poses' paper=True)
    assert m.paper_fit_x is not None and m.paper_fit_y is not None
    return Maps(cmd, m, m.paper_fit_x, m.paper_fit_y, std)


def check_compensation(
    sim: BeltStageSim,
    config: BeltStageConfig,
    fit_x: QuadraticFit,
    fit_y: QuadraticFit,
    rng: np.random.Generator,
) -> Compensation:
    """Step 5: ``config.n_check`` uniform random targets in the travel, each commanded as it is and
    then compensated by the maps ``fit_x``, ``fit_y``; the true position's miss each time.

    Returns
    -------
    Compensation
        (n_check, 2) targets, misses before and after, mm.
    """
    targets = rng.uniform([0, 0], config.geometry.travel_mm, size=(config.n_check, 2))
    comp = np.stack(compensated_command(targets[:, 0], targets[:, 1], fit_x, fit_y), axis=1)
    before, after = [], []
    for (tx, ty), c in zip(targets, comp):
        before.append(sim.move(*np.rint(np.array([tx, ty]) * PULSES_PER_MM)) - (tx, ty))
        after.append(sim.move(*np.rint(c * PULSES_PER_MM)) - (tx, ty))
    return Compensation(targets, np.array(before), np.array(after))
