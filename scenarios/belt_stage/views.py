"""The belt stage's camera views as its estimators get them: the sim driven through the steps,
each view rendered and its corners detected (fidelity ``render``), or the true corners with the
detector's noise (``analytic``)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from calibench.estimators.camera.chessboard import find_chessboard_corners
from calibench.recordings import CameraViews
from calibench.scenarios.report import progress
from calibench.sim.belt_stage import PULSES_PER_MM, BeltStageSim
from calibench.sim.frame_workers import develop_all
from calibench.sim.renderer import Exposure

if TYPE_CHECKING:
    from calibench.scenarios.belt_stage.scenario import BeltStageConfig


def record_views(
    sim: BeltStageSim,
    fidelity: str,
    config: BeltStageConfig,
    rng: np.random.Generator,
    size,
    steps,
    windowed: bool = False,
    workers: int = 0,
) -> tuple[CameraViews, np.ndarray]:
    """Drive the sim through ``steps`` and record what the camera gives the estimators.

    Parameters
    ----------
    sim : BeltStageSim
        The stage (with a renderer for fidelity ``render``).
    fidelity : str
        ``"render"`` or ``"analytic"``.
    config : BeltStageConfig
        The board, the sensor's noise and blur, the analytic detector's noise.
    rng : numpy.random.Generator
        Draws the noise, view by view in the steps' order.
    size : tuple of int
        The image's (width, height), px.
    steps : iterable of (kind, a, b)
        ``("calib", R, t)`` places the free board; ``("station", x_pulses, y_pulses)`` drives
        the stage.
    windowed : bool
        Each view read out over the board's area of interest only (a study's trial, which keeps
        no image: the same corners at a fraction of the render); no image is kept.
    workers : int
        Threads that develop and detect the rendered views while this one renders the next
        (:func:`calibench.sim.frame_workers.develop_all`); the views are the same whatever the
        number.

    Returns
    -------
    views : CameraViews
        Images (where kept) and detected corners, NaN where undetected.
    true : ndarray, (n_views, n_corners, 2)
        The true corner projections, which stay in the scenario.
    """
    board = config.geometry.board
    names: list[str] = []
    frames = []

    def captures():
        for kind, a, b in progress(list(steps), "rendering" if fidelity == "render" else "views"):
            calib = kind == "calib"
            if calib:
                sim.place_calib_board(a, b)
                names.append(f"view{len(names):02d}")
            else:
                sim.move(a, b)
                names.append(f"x{a / PULSES_PER_MM:g}_y{b / PULSES_PER_MM:g}")
            frames.append(sim.view_frame(calib=calib))
            if fidelity == "render":
                window = sim.board_window(calib) if windowed else None
                yield sim.capture(calib, rng, config.pixel_noise_dn, config.psf_px, window)

    def detect(exposure: Exposure) -> tuple[np.ndarray, np.ndarray]:
        assert sim.renderer is not None  # captured by it
        img = sim.renderer.develop(exposure)
        c = find_chessboard_corners(img, board.cols, board.rows)
        if c is None:
            return img, np.full((board.n_corners, 2), np.nan)
        if exposure.window is not None:  # the window's pixels to the image's
            c = c + np.asarray(exposure.window[:2])
        return img, c

    shot = develop_all(captures(), detect, workers if fidelity == "render" else 0)
    true = sim.corners_px(frames)
    if fidelity == "render":
        images = None if windowed else [img for img, _ in shot]
        corners = np.array([c for _, c in shot])
    else:  # every view's noise at once: the same draws as view by view
        images, corners = None, true + rng.normal(0, config.corner_noise_px, true.shape)
    views = CameraViews(image_size=size, names=names, images=images, corners_px=corners)
    return views, true
