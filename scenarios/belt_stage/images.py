"""The belt stage's rendered views with their truth: ``calibench run belt-stage --save-images
DIR``, for a user who wants to test any camera calibration tool on a camera of known intrinsics.

The views are the run's own (the same seed draws the same poses and the same noise): the tilted
views of the free calibration board, then the board on the stage at each station. DIR gets each
view as a PNG and ``truth.json``: the camera's true intrinsics (OpenCV's model, K and k1 k2 p1 p2
k3), the board (inner corners, square), and each view's exact corner projections in pixels
(OpenCV's convention: the top-left pixel's centre at (0, 0)).
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import cv2
import numpy as np

from calibench.scenarios.belt_stage.scenario import BeltStageConfig
from calibench.scenarios.belt_stage.views import record_views
from calibench.scenarios.cvplot import write_png
from calibench.scenes.camera import PinholeCamera
from calibench.sim.belt_stage import PULSES_PER_MM, BeltStageSim, intrinsic_view_poses
from calibench.sim.frame_workers import frame_workers
from calibench.writing import write_text


def save_rendered_views(config: BeltStageConfig, seed: int, folder: Path) -> dict:
    """Render the run's views (seed ``seed``) into ``folder`` with truth.json; returns its
    content.

    Parameters
    ----------
    config : BeltStageConfig
        The run's config (its camera is the truth written).
    seed : int
        The run's seed: the views are those ``calibench run belt-stage --seed`` renders.
    folder : Path
        Where the PNGs and truth.json go (made if missing).
    """
    rng = np.random.default_rng(seed)
    g = config.geometry
    sim = BeltStageSim(g, config.truth, render=True)
    size = (g.camera.width, g.camera.height)
    try:
        poses = intrinsic_view_poses(g, config.n_intrinsic_views, rng)
        workers = frame_workers()
        calib, calib_true = record_views(
            sim, "render", config, rng, size, [("calib", *p) for p in poses], False, workers
        )
        sim.park_calib_board()
        # the stations as the run drives them (scenario.run, step 2)
        xs, ys = np.meshgrid(config.stations_x_mm, config.stations_y_mm)
        x_pulses = np.rint(xs.ravel() * PULSES_PER_MM).astype(np.int64)
        y_pulses = np.rint(ys.ravel() * PULSES_PER_MM).astype(np.int64)
        steps = [("station", xp, yp) for xp, yp in zip(x_pulses, y_pulses)]
        stations, station_true = record_views(
            sim, "render", config, rng, size, steps, False, workers
        )
    finally:
        sim.close()
    folder.mkdir(parents=True, exist_ok=True)
    views = {}
    for views_of, true in ((calib, calib_true), (stations, station_true)):
        assert views_of.images is not None  # rendered, not windowed: every image kept
        for name, img, corners in zip(views_of.names, views_of.images, true):
            write_png(folder / f"{name}.png", cv2.cvtColor(img, cv2.COLOR_RGB2BGR))
            views[f"{name}.png"] = np.asarray(corners).round(4).tolist()
    truth = {
        "camera": _camera(g.camera),
        "board": {
            "cols": g.board.cols,
            "rows": g.board.rows,
            "square_mm": g.board.square_mm,
            "note": "cols x rows inner corners (calibench camera's --cols --rows)",
        },
        "seed": seed,
        "corners_px": views,
    }
    write_text(folder / "truth.json", json.dumps(truth, indent=1) + "\n")
    return truth


def _camera(cam: PinholeCamera) -> dict:
    """The camera in OpenCV's terms."""
    c = dataclasses.asdict(cam)
    return {
        "image_size": [c["width"], c["height"]],
        "K": [[c["fx"], 0.0, c["cx"]], [0.0, c["fy"], c["cy"]], [0.0, 0.0, 1.0]],
        "dist": [c[k] for k in ("k1", "k2", "p1", "p2", "k3")],
        "distortion": {k: c[k] for k in ("k1", "k2", "p1", "p2", "k3")},
    }
