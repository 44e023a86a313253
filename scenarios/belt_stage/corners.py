"""Chessboard corners on the belt stage's renders: calibench's saddle refinement against OpenCV's
classic pipeline (findChessboardCorners, then cornerSubPix in an 11 x 11 window) on the same
images, both against the exact projection of the true corners (the README's corner accuracy)."""

from __future__ import annotations

import cv2
import numpy as np

from calibench.estimators.camera.chessboard import find_chessboard_corners
from calibench.scenes.belt_stage import BeltStageGeometry
from calibench.sim.belt_stage import BeltStageSim, BeltStageTruth

STANDOFF_MM = 900.0  # the board's centroid from the camera, along the camera's axis
OPENCV_HALF_WINDOW = (5, 5)  # cornerSubPix's half window: an 11 x 11 window


def corner_rms_by_tilt(
    tilts_rad, n_azimuths: int = 4, azimuth0_rad: float = 0.3, seed: int = 0
) -> dict[str, list[float]]:
    """The corners' RMS error (px) at each tilt of the calibration board, ours and OpenCV's.

    At each tilt the board is turned about ``n_azimuths`` axes in its plane, evenly spaced from
    ``azimuth0_rad``, its centroid ``STANDOFF_MM`` in front of the camera; each pose is rendered
    with the belt stage's blur and sensor noise (one generator, seeded ``seed``, for all
    renders), and the corners each method finds are compared with the exact projection of the
    true ones (OpenCV's paired to the nearest, since its order may differ).

    Parameters
    ----------
    tilts_rad : sequence of float, (T,)
        The board's tilts from facing the camera (rad).
    n_azimuths : int
        Tilt axes per tilt.
    azimuth0_rad : float
        The first tilt axis's angle in the board's plane (rad).
    seed : int
        Seed of the renders' noise.

    Returns
    -------
    dict
        ``{"ours": [T floats], "opencv": [T floats]}``, RMS over the corners of every view at
        that tilt (px).
    """
    g = BeltStageGeometry()
    sim = BeltStageSim(g, BeltStageTruth())
    rng = np.random.default_rng(seed)
    stop = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 100, 1e-4)
    rms: dict[str, list[float]] = {"ours": [], "opencv": []}
    try:
        for tilt in tilts_rad:
            ours, opencv = [], []
            for azimuth in np.arange(n_azimuths) * (2 * np.pi / n_azimuths) + azimuth0_rad:
                R = cv2.Rodrigues(tilt * np.array([np.cos(azimuth), np.sin(azimuth), 0.0]))[0]
                sim.place_calib_board(
                    R, np.array([0.0, 0.0, STANDOFF_MM]) - R @ g.board.corners_mm().mean(axis=0)
                )
                img = sim.render(calib=True, rng=rng)
                truth = sim.true_corners_px(calib=True)
                grey = cv2.cvtColor(img, cv2.COLOR_RGB2GRAY)
                ok, c = cv2.findChessboardCorners(grey, (g.board.cols, g.board.rows))
                if not ok:
                    raise RuntimeError(f"OpenCV found no board at tilt {tilt} rad")
                c = cv2.cornerSubPix(grey, c, OPENCV_HALF_WINDOW, (-1, -1), stop).reshape(-1, 2)
                nearest = np.argmin(np.linalg.norm(c[:, None] - truth[None], axis=2), axis=1)
                opencv.append(np.linalg.norm(c - truth[nearest], axis=1))
                ours.append(
                    np.linalg.norm(
                        find_chessboard_corners(img, g.board.cols, g.board.rows) - truth, axis=1
                    )
                )
            for key, e in (("ours", ours), ("opencv", opencv)):
                rms[key].append(float(np.sqrt(np.mean(np.concatenate(e) ** 2))))
    finally:
        sim.close()
    return rms
