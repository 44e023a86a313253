"""Scenario ``belt-stage``: calibrate the camera, map both axes' positioning errors, compensate.

The procedure of the seed paper, end to end:

1. Zhang calibration from ~20 tilted views of the chessboard (intrinsics with their std).
2. The board rides the carriage over the paper's 11 x 11 station grid (commanded in pulses);
   each station's board2cam pose comes from the homography's closed form (Eq. 13-18), refined
   and cross-checked by PnP.
3. Travel = displacement of the board from the home station; error = travel - pulse travel.
   The paper takes camera-centre differences and assumes the board square to the axes; here
   the board's centroid is tracked on the plane of motion fitted through all stations, and
   the board's yaw to the axes is estimated.
4. A bivariate quadratic map per axis (Eq. 1), with SSE, R^2, RMSE and coefficient std.
5. Compensation checked at 20 random points that no fit saw.

Fidelity ``render`` renders every view through the lens and detects corners in the pixels;
``analytic`` projects the true corners exactly and adds the detector's noise.

The steps are :mod:`.procedure`'s (views, calibration, maps, compensation); here the config,
``run`` that takes them in turn, and the report that compares what they found with the truth.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from calibench.estimators.camera.zhang import CameraCalibration
from calibench.estimators.stage.error_map import COEF_NAMES, QuadraticFit
from calibench.scenarios.belt_stage import NAME
from calibench.scenarios.belt_stage.checks import check_config
from calibench.scenarios.belt_stage.procedure import (
    Compensation,
    IntrinsicViews,
    Maps,
    StationViews,
    calibrate,
    calibration_points,
    check_compensation,
    intrinsic_views,
    measure,
    station_views,
)
from calibench.scenarios.harness import write_outputs
from calibench.scenarios.report import Check, Parameter, Report
from calibench.scenarios.run_recording import StageRecordingPlan, check_plan, write_recording
from calibench.scenes.belt_stage import BeltStageGeometry
from calibench.sim.belt_stage import BeltStageSim, BeltStageTruth
from calibench.sim.frame_workers import frame_workers

# The paper's 121 stations (Tables 1-2), mm.
PAPER_STATIONS_X = (0, 100, 170, 230, 310, 400, 540, 610, 760, 890, 980)
PAPER_STATIONS_Y = (0, 80, 170, 250, 310, 460, 520, 640, 710, 890, 920)


@dataclasses.dataclass(frozen=True)
class BeltStageConfig:
    geometry: BeltStageGeometry = BeltStageGeometry()
    truth: BeltStageTruth = BeltStageTruth()
    n_intrinsic_views: int = 20
    # Sensor noise of the rendered images, 1-sigma in grey levels (an 8-bit machine-vision
    # camera at mid grey: read plus shot noise of 1-3 levels).
    pixel_noise_dn: float = 2.0
    # Optics' point-spread function, Gaussian 1-sigma in pixels (a sharp lens slightly defocused).
    psf_px: float = 0.8
    # Detector noise of the analytic fidelity, per axis, 1-sigma (calibrated on renders of
    # this scene with the sensor below: 0.012 px RMS in 2-D on stations and tilted views alike).
    corner_noise_px: float = 0.0085
    stations_x_mm: tuple[float, ...] = PAPER_STATIONS_X
    stations_y_mm: tuple[float, ...] = PAPER_STATIONS_Y
    n_check: int = 20
    map_limit_mm: float = 0.1
    corner_limit_px: float = 0.1

    # [belt-stage.recording]: what DIR/recording.csv records and conceals (run_recording.py)
    recording: StageRecordingPlan = StageRecordingPlan()

    def __post_init__(self):
        check_plan(NAME, self.recording, self.geometry.travel_mm)
        check_config(self)


def run(config: BeltStageConfig, seed: int, fidelity: str, out_dir: Path, rrd: bool) -> Report:
    """Simulate the belt-driven XY stage watched by its overhead camera; calibrate it from what its
    sensors recorded; compare with the truth.

    The arguments and the Report: :class:`calibench.scenarios.registry.Scenario`.
    """
    rng = np.random.default_rng(seed)
    g = config.geometry
    board_pts = g.board.corners_mm()
    sim = BeltStageSim(g, config.truth, render=fidelity == "render")
    try:
        # a study's trial keeps no image, and its processes fill the cores: the views are read
        # out over the board's area only and developed in turn
        windowed = out_dir is None
        workers = 0 if windowed else frame_workers()
        intrinsic = intrinsic_views(sim, config, fidelity, rng, windowed, workers)
        stations = station_views(sim, config, fidelity, rng, windowed, workers)
        calib_points = calibration_points(intrinsic, stations)
        calib = calibrate(config, board_pts, calib_points)
        maps = measure(board_pts, stations, calib, calib_points)
        comp = check_compensation(sim, config, maps.maps.fit_x, maps.maps.fit_y, rng)

        report = Report(scenario=NAME, seed=seed, fidelity=fidelity)
        report.parameters += report_parameters(config, calib, maps)
        report.checks += report_checks(config, stations, maps, comp)
        report.info = report_info(config, intrinsic, calib, maps)
        if sim.renderer is not None:  # a GPU's name, or llvmpipe's: frames made on the CPU
            report.info["renderer"] = sim.renderer.gl_renderer
        artifacts = {
            "sim": sim,
            "calib": calib,
            "calib_views": intrinsic.views,
            "calib_true": intrinsic.true_px,
            "station_views": stations.views,
            "station_true": stations.true_px,
            "cmd": maps.cmd,
            "err": maps.maps.err,
            "fits": (maps.maps.fit_x, maps.maps.fit_y),
            "targets": comp.targets,
            "before": comp.before,
            "after": comp.after,
            "travel": maps.maps.travel,
            "truth": config.truth,
            "geometry": g,
            "x_pulses": stations.x_pulses,
            "y_pulses": stations.y_pulses,
            "limit_mm": config.map_limit_mm,
        }
        write_recording(out_dir, NAME, config, seed, report.info)
        return write_outputs(report, artifacts, out_dir, rrd, "calibench.scenarios.belt_stage")
    finally:
        sim.close()


def report_parameters(
    config: BeltStageConfig, calib: CameraCalibration, maps: Maps
) -> list[Parameter]:
    """The report's parameters, truth against estimate: the intrinsics (fx .. p2), both maps'
    coefficients (ex_c0 .. ey_c5) and the board's yaw (board_yaw_mrad), each within
    ``TOL_SIGMA`` of its std (:class:`Maps`' ``std``, (13,))."""
    truth, m, std_map = config.truth, maps.maps, maps.std
    return [
        *_intrinsic_parameters(config.geometry.camera, calib),
        *_map_parameters("ex", truth.error_x, m.fit_x.coef, std_map[:6]),
        *_map_parameters("ey", truth.error_y, m.fit_y.coef, std_map[6:12]),
        Parameter(
            "board_yaw_mrad",
            "mrad",
            truth.board_yaw_rad * 1e3,
            m.yaw_rad * 1e3,
            std_map[12] * 1e3,
            tolerance=TOL_SIGMA * std_map[12] * 1e3,
        ),
    ]


def map_rms_mm(
    truth: BeltStageTruth, travel_mm: tuple[float, float], fit_x: QuadraticFit, fit_y: QuadraticFit
) -> float:
    """The maps ``fit_x``, ``fit_y`` against the true error map: the vector RMS over a 41 x 41
    grid of the travel, mm."""
    gx, gy = np.meshgrid(*(np.linspace(0, t, 41) for t in travel_mm))
    gx, gy = gx.ravel(), gy.ravel()
    return _vector_rms(np.stack([fit_x(gx, gy), fit_y(gx, gy)], 1) - truth.error_mm(gx, gy))


def report_checks(
    config: BeltStageConfig, stations: StationViews, maps: Maps, comp: Compensation
) -> list[Check]:
    """The report's checks: the corners' fidelity on the stations (detected against the exact
    projection of the true corners, px), the map against the truth, the check points before and
    after compensation (mm), and the closed-form poses against PnP's (mm)."""
    corner_err = stations.corners_px - stations.true_px
    corner_rms = float(np.sqrt(np.nanmean(np.sum(corner_err**2, axis=-1))))
    m = maps.maps
    return [
        Check(
            "corner_rms_px",
            corner_rms,
            config.corner_limit_px,
            note="stations: detected corners vs exact projection of the true corners",
        ),
        Check(
            "map_rms_mm",
            map_rms_mm(config.truth, config.geometry.travel_mm, m.fit_x, m.fit_y),
            config.map_limit_mm,
            note="estimated vs true error map, vector RMS over a 41 x 41 grid of the travel",
        ),
        Check(
            "check_rms_before_mm",
            _vector_rms(comp.before),
            None,
            note=f"{config.n_check} check points, no compensation",
        ),
        Check(
            "check_rms_after_mm",
            _vector_rms(comp.after),
            config.map_limit_mm,
            note=f"{config.n_check} check points, commands compensated by the fitted maps",
        ),
        Check(
            "pose_crosscheck_mm",
            float(np.max(m.poses.in_plane_gap_mm())),
            3.0,
            note="largest in-plane gap between closed-form (Eq. 13-18) and PnP station poses; "
            "the closed form takes its scale from one column of H, so it scatters more",
        ),
    ]


def report_info(
    config: BeltStageConfig, intrinsic: IntrinsicViews, calib: CameraCalibration, maps: Maps
) -> dict:
    """The report's extra figures: the intrinsic views used and rejected, the calibration's
    reprojection RMS and the corners' fidelity on its views (px), both fits, the seed paper's
    method with its map against the truth (mm), the number of stations."""
    used = intrinsic.used
    calib_err = intrinsic.corners_px[used] - intrinsic.true_px[used]
    m = maps.maps
    return {
        "intrinsic_views_used": int(used.sum()),
        "intrinsic_views_rejected": [intrinsic.views.names[i] for i in np.flatnonzero(~used)],
        "calibration_rms_px": calib.rms_px,
        "corner_rms_calib_views_px": float(np.sqrt(np.mean(np.sum(calib_err**2, axis=-1)))),
        "fit": {
            "x": m.fit_x.as_dict(),
            "y": m.fit_y.as_dict(),
            "note": "std in report parameters adds the intrinsics' covariance to the fit's own",
        },
        "paper_method": {
            "note": "camera-centre differences, board assumed square to the axes",
            "map_rms_mm": map_rms_mm(
                config.truth, config.geometry.travel_mm, maps.paper_fit_x, maps.paper_fit_y
            ),
            "fit": {"x": maps.paper_fit_x.as_dict(), "y": maps.paper_fit_y.as_dict()},
        },
        "stations": len(maps.cmd),
    }


TOL_SIGMA = 5.0  # parameter tolerance, in the estimator's own standard deviations


def _vector_rms(d: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.sum(np.asarray(d) ** 2, axis=-1))))


def _intrinsic_parameters(camera, calib) -> list[Parameter]:
    truth = dataclasses.asdict(camera)
    est = calib.params()
    out = []
    for name in ("fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2"):
        std = calib.std.get(name)
        unit = "px" if name in ("fx", "fy", "cx", "cy") else "1"
        # the estimator's own std, with a floor for renders whose corner noise is not quite
        # independent
        floor = 0.5 if unit == "px" else 2e-3
        out.append(
            Parameter(
                name, unit, truth[name], est[name], std, tolerance=max(TOL_SIGMA * std, floor)
            )
        )
    return out


def _map_parameters(prefix: str, truth_coef, coef, std) -> list[Parameter]:
    units = ("mm", "mm/mm", "mm/mm", "mm/mm^2", "mm/mm^2", "mm/mm^2")
    return [
        Parameter(f"{prefix}_{n}", u, float(t), float(e), float(s), tolerance=TOL_SIGMA * float(s))
        for n, u, t, e, s in zip(COEF_NAMES, units, truth_coef, coef, std)
    ]


def prior(config: BeltStageConfig, rng: np.random.Generator) -> BeltStageConfig:
    """Error-map coefficients c1..c5 each scaled by 1 + 0.2 N(0, 1) (mm, mm/mm, mm/mm^2; c0 = 0 by
    homing); board yaw uniform in +-5 mrad."""
    t = config.truth
    ex = (0.0,) + tuple(np.array(t.error_x[1:]) * (1 + 0.2 * rng.standard_normal(5)))
    ey = (0.0,) + tuple(np.array(t.error_y[1:]) * (1 + 0.2 * rng.standard_normal(5)))
    truth = dataclasses.replace(
        t, error_x=ex, error_y=ey, board_yaw_rad=float(rng.uniform(-5e-3, 5e-3))
    )
    return dataclasses.replace(config, truth=truth)
