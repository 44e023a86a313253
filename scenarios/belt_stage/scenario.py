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
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from calibench.errors import BadInput
from calibench.estimators.camera.zhang import calibrate_camera
from calibench.estimators.stage.belt_maps import (
    MAP_INTRINSICS,
    intrinsics_cov,
    measure_maps,
    propagated_std,
)
from calibench.estimators.stage.error_map import COEF_NAMES, compensated_command
from calibench.scenarios.belt_stage.checks import check_config
from calibench.scenarios.belt_stage.views import record_views
from calibench.scenarios.harness import write_outputs
from calibench.scenarios.report import Check, Parameter, Report
from calibench.scenarios.run_recording import StageRecordingPlan, check_plan, write_recording
from calibench.scenes.belt_stage import BeltStageGeometry
from calibench.sim.belt_stage import (
    PULSES_PER_MM,
    BeltStageSim,
    BeltStageTruth,
    intrinsic_view_poses,
)
from calibench.sim.developing import frame_workers

NAME = "belt-stage"

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
    g, truth = config.geometry, config.truth
    board_pts = g.board.corners_mm()
    sim = BeltStageSim(g, truth, render=fidelity == "render")
    size = (g.camera.width, g.camera.height)
    try:
        # 1. intrinsic views ------------------------------------------------------------------
        poses = intrinsic_view_poses(g, config.n_intrinsic_views, rng)
        # a study's trial keeps no image, and its processes fill the cores: the views are read
        # out over the board's area only and developed in turn
        windowed = out_dir is None
        workers = 0 if windowed else frame_workers()
        calib_views, calib_true = record_views(
            sim, fidelity, config, rng, size, [("calib", R, t) for R, t in poses], windowed, workers
        )
        sim.park_calib_board()
        used = np.isfinite(calib_views.corners_px).all(axis=(1, 2))

        # 2. stations -------------------------------------------------------------------------
        xs, ys = np.meshgrid(config.stations_x_mm, config.stations_y_mm)
        x_pulses = np.rint(xs.ravel() * PULSES_PER_MM).astype(np.int64)
        y_pulses = np.rint(ys.ravel() * PULSES_PER_MM).astype(np.int64)
        home = np.flatnonzero((x_pulses == 0) & (y_pulses == 0))
        if len(home) != 1:
            raise BadInput("the station grid must contain the home station (0, 0) once")
        ref = int(home[0])
        station_views, station_true = record_views(
            sim,
            fidelity,
            config,
            rng,
            size,
            [("station", xp, yp) for xp, yp in zip(x_pulses, y_pulses)],
            windowed,
            workers,
        )
        if not np.isfinite(station_views.corners_px).all():
            missed = [
                station_views.names[i]
                for i in np.flatnonzero(~np.isfinite(station_views.corners_px).all(axis=(1, 2)))
            ]
            raise ValueError(f"board not detected at station(s) {', '.join(missed[:5])}")

        # Zhang on the tilted views; the station views join them: fronto-parallel, they say
        # nothing of the focal length, but they sample the lens over the whole image.
        calib_points = list(calib_views.corners_px[used]) + list(station_views.corners_px)
        calib = calibrate_camera(board_pts, calib_points, size, fix_k3=True)

        # 3-4. poses, travel, errors, maps; then the intrinsics' uncertainty carried through
        cmd = np.stack([x_pulses, y_pulses], axis=1) / PULSES_PER_MM
        m = measure_maps(board_pts, station_views.corners_px, calib.K, calib.dist, cmd, ref)
        cov_intr = intrinsics_cov(calib, board_pts, calib_points)
        std_map = propagated_std(
            m, board_pts, calib.K, calib.dist, cmd, ref, MAP_INTRINSICS, cov_intr
        )
        fit_x, fit_y, yaw, err = m.fit_x, m.fit_y, m.yaw_rad, m.err
        gx, gy = np.meshgrid(*(np.linspace(0, t, 41) for t in g.travel_mm))
        gx, gy = gx.ravel(), gy.ravel()
        true_grid = truth.error_mm(gx, gy)
        map_rms = _vector_rms(np.stack([fit_x(gx, gy), fit_y(gx, gy)], 1) - true_grid)
        pfit_x, pfit_y = m.paper_fit_x, m.paper_fit_y
        map_rms_paper = _vector_rms(np.stack([pfit_x(gx, gy), pfit_y(gx, gy)], 1) - true_grid)
        st = m.poses

        # 5. compensation at unseen check points ----------------------------------------------
        targets = rng.uniform([0, 0], g.travel_mm, size=(config.n_check, 2))
        comp = np.stack(compensated_command(targets[:, 0], targets[:, 1], fit_x, fit_y), axis=1)
        before, after = [], []
        for (tx, ty), c in zip(targets, comp):
            before.append(sim.move(*np.rint(np.array([tx, ty]) * PULSES_PER_MM)) - (tx, ty))
            after.append(sim.move(*np.rint(c * PULSES_PER_MM)) - (tx, ty))
        before, after = np.array(before), np.array(after)

        # corner fidelity: detected against the exact projection of the true corners
        corner_err = station_views.corners_px - station_true
        corner_rms = float(np.sqrt(np.nanmean(np.sum(corner_err**2, axis=-1))))
        calib_err = calib_views.corners_px[used] - calib_true[used]
        corner_rms_calib = float(np.sqrt(np.mean(np.sum(calib_err**2, axis=-1))))
        pose_gap = float(np.max(st.in_plane_gap_mm()))

        report = Report(scenario=NAME, seed=seed, fidelity=fidelity)
        report.parameters += _intrinsic_parameters(g.camera, calib)
        report.parameters += _map_parameters("ex", truth.error_x, fit_x.coef, std_map[:6])
        report.parameters += _map_parameters("ey", truth.error_y, fit_y.coef, std_map[6:12])
        report.parameters.append(
            Parameter(
                "board_yaw_mrad",
                "mrad",
                truth.board_yaw_rad * 1e3,
                yaw * 1e3,
                std_map[12] * 1e3,
                tolerance=TOL_SIGMA * std_map[12] * 1e3,
            )
        )
        report.checks += [
            Check(
                "corner_rms_px",
                corner_rms,
                config.corner_limit_px,
                note="stations: detected corners vs exact projection of the true corners",
            ),
            Check(
                "map_rms_mm",
                map_rms,
                config.map_limit_mm,
                note="estimated vs true error map, vector RMS over a 41 x 41 grid of the travel",
            ),
            Check(
                "check_rms_before_mm",
                _vector_rms(before),
                None,
                note=f"{config.n_check} check points, no compensation",
            ),
            Check(
                "check_rms_after_mm",
                _vector_rms(after),
                config.map_limit_mm,
                note=f"{config.n_check} check points, commands compensated by the fitted maps",
            ),
            Check(
                "pose_crosscheck_mm",
                pose_gap,
                3.0,
                note="largest in-plane gap between closed-form (Eq. 13-18) and PnP station poses; "
                "the closed form takes its scale from one column of H, so it scatters more",
            ),
        ]
        report.info = {
            "intrinsic_views_used": int(used.sum()),
            "intrinsic_views_rejected": [calib_views.names[i] for i in np.flatnonzero(~used)],
            "calibration_rms_px": calib.rms_px,
            "corner_rms_calib_views_px": corner_rms_calib,
            "fit": {
                "x": fit_x.as_dict(),
                "y": fit_y.as_dict(),
                "note": "std in report parameters adds the intrinsics' covariance to the fit's own",
            },
            "paper_method": {
                "note": "camera-centre differences, board assumed square to the axes",
                "map_rms_mm": map_rms_paper,
                "fit": {"x": pfit_x.as_dict(), "y": pfit_y.as_dict()},
            },
            "stations": len(cmd),
        }
        if sim.renderer is not None:  # a GPU's name, or llvmpipe's: frames made on the CPU
            report.info["renderer"] = sim.renderer.gl_renderer
        artifacts = {
            "sim": sim,
            "calib": calib,
            "calib_views": calib_views,
            "calib_true": calib_true,
            "station_views": station_views,
            "station_true": station_true,
            "cmd": cmd,
            "err": err,
            "fits": (fit_x, fit_y),
            "targets": targets,
            "before": before,
            "after": after,
            "travel": m.travel,
            "truth": truth,
            "geometry": g,
            "x_pulses": x_pulses,
            "y_pulses": y_pulses,
            "limit_mm": config.map_limit_mm,
        }
        write_recording(out_dir, NAME, config, seed, report.info)
        return write_outputs(report, artifacts, out_dir, rrd, "calibench.scenarios.belt_stage")
    finally:
        sim.close()


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
