"""What a ``belt-stage`` run shows in rerun (all calls go through ``scenarios.rrlog``).

Timelines: ``view`` for the intrinsic calibration views, ``station`` for the stage stations.
World units are metres; error vectors are drawn magnified (``ARROW_GAIN``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from calibench.scenarios import rrlog
from calibench.scenarios.harness import FIGURE
from calibench.sim.belt_stage import PULSES_PER_MM

ARROW_GAIN = 20.0  # error arrows are drawn 20 x their size


def log_run(path: Path, report, a: dict) -> None:
    """Write the run's rerun recording to ``path`` with its layout."""
    path.parent.mkdir(parents=True, exist_ok=True)
    rec = rrlog.open_recording(path, "calibench-belt-stage")
    try:
        sim, g = a["sim"], a["geometry"]
        model = sim.model
        texture = g.board.texture(16)
        paths = rrlog.log_mujoco_bodies(
            rec, model, textures={"board": texture, "calib_board": texture}
        )
        V = rrlog.View
        rrlog.send_layout(
            rec,
            [
                [
                    V("3d", "world", "the stage", eye=rrlog.eye_on(model)),
                    V(
                        "3d",
                        "error_map",
                        f"error map (arrows x{ARROW_GAIN:g}): true red, measured green, fitted "
                        "blue",
                    ),
                ],
                [
                    V("2d", "world/overhead", "overhead camera: detected green, true red"),
                    V("2d", "calibration", "calibration views"),
                ],
                [
                    V("plot", "error_map/station_error_mm", "station error (mm) by station"),
                    V("text", "report", "truth against estimate"),
                    V("2d", "figures", "error maps"),
                ],
            ],
            "station",
        )
        R_c2w, p_c2w = sim.cam2world()
        cam = g.camera
        rrlog.log_camera(rec, "world/overhead", cam.K, (cam.width, cam.height), R_c2w, p_c2w)
        calib = a["calib"]
        rrlog.log_camera(
            rec, "calibration", calib.K, (cam.width, cam.height), np.eye(3), np.zeros(3)
        )

        # calibration views: images with detected (green) and true (red) corners
        views, true = a["calib_views"], a["calib_true"]
        for i in range(len(views.names)):
            rrlog.set_step(rec, "view", i)
            if views.images is not None:
                rrlog.log_image(rec, "calibration/image", views.images[i])
            rrlog.log_points2d(rec, "calibration/image/true", true[i], rrlog.RED, 2.0)
            rrlog.log_points2d(
                rec, "calibration/image/detected", views.corners_px[i], rrlog.GREEN, 1.2
            )

        # stations: stage pose, image, corners, measured error
        st, st_true = a["station_views"], a["station_true"]
        for i, (xp, yp) in enumerate(zip(a["x_pulses"], a["y_pulses"])):
            rrlog.set_step(rec, "station", i)
            sim.move(int(xp), int(yp))
            rrlog.log_body_poses(rec, paths, sim.data.xpos, sim.data.xquat, model.body_parentid)
            if st.images is not None:
                rrlog.log_image(rec, "world/overhead/image", st.images[i])
            rrlog.log_points2d(rec, "world/overhead/image/true", st_true[i], rrlog.RED, 2.0)
            rrlog.log_points2d(
                rec, "world/overhead/image/detected", st.corners_px[i], rrlog.GREEN, 1.2
            )
            rrlog.log_scalar(rec, "error_map/station_error_mm/x", a["err"][i, 0])
            rrlog.log_scalar(rec, "error_map/station_error_mm/y", a["err"][i, 1])

        # the maps, on the stage's plane (z = board top), arrows magnified
        z = g.board_top_mm / 1000 + 0.002
        cmd = a["cmd"]
        origins = np.c_[cmd / 1000, np.full(len(cmd), z)]
        fit_x, fit_y = a["fits"]
        true_err = a["truth"].error_mm(cmd[:, 0], cmd[:, 1])
        rrlog.log_arrows3d(rec, "error_map/true", origins, _vec(true_err), rrlog.RED)
        rrlog.log_arrows3d(rec, "error_map/measured", origins, _vec(a["err"]), rrlog.GREEN)
        fitted = np.c_[fit_x(cmd[:, 0], cmd[:, 1]), fit_y(cmd[:, 0], cmd[:, 1])]
        rrlog.log_arrows3d(rec, "error_map/fitted", origins, _vec(fitted), rrlog.BLUE)
        t = a["targets"]
        t_org = np.c_[t / 1000, np.full(len(t), z)]
        rrlog.log_arrows3d(rec, "error_map/check_before", t_org, _vec(a["before"]), rrlog.ORANGE)
        rrlog.log_arrows3d(rec, "error_map/check_after", t_org, _vec(a["after"]) * 10, rrlog.GREEN)
        rrlog.log_text(
            rec,
            "report",
            f"# belt-stage, seed {report.seed}, {report.fidelity}\n\n"
            f"Error arrows x{ARROW_GAIN:g} (check_after x{10 * ARROW_GAIN:g}); stage "
            f"commands in pulses ({PULSES_PER_MM:g} per mm).\n\n" + report.table(),
        )
        png = path.parent / FIGURE
        if png.exists():
            rrlog.log_figure(rec, "figures/error_map", png)
    finally:
        rrlog.close(rec)


def _vec(err_mm: np.ndarray) -> np.ndarray:
    """Error (n, 2) mm to magnified arrows (n, 3) m."""
    return np.c_[err_mm * ARROW_GAIN / 1000, np.zeros(len(err_mm))]
