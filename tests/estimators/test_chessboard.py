"""Corner detection on exact synthetic images (no MuJoCo): accuracy, order, refusal."""

import cv2
import numpy as np
import pytest

from calibench.estimators.chessboard import find_chessboard_corners, refine_saddle
from calibench.scenes.checkerboard import Chessboard
from tests.estimators.synthetic import project, raster_chessboard

BOARD = Chessboard(cols=9, rows=6, square_mm=25.0, margin_mm=25.0)
K = np.array([[600.0, 0, 320], [0, 600, 240], [0, 0, 1]])


@pytest.mark.parametrize("rotvec", [(0.0, 0.0, 0.05), (0.5, -0.3, 0.2), (-0.6, 0.4, 2.9)])
def test_corners_are_found_to_a_twentieth_of_a_pixel(rotvec):
    R = cv2.Rodrigues(np.array(rotvec))[0]
    t = np.array([0.0, 0.0, 600.0]) - R @ BOARD.corners_mm().mean(axis=0)
    img = raster_chessboard(BOARD, K, R, t)
    found = find_chessboard_corners(img, BOARD.cols, BOARD.rows)
    truth = project(BOARD.corners_mm(), K, R, t)
    assert found is not None
    # board order, even for a board turned by ~166 degrees in the image
    err = np.linalg.norm(found - truth, axis=1)
    assert np.sqrt(np.mean(err**2)) < 0.05
    assert err.max() < 0.15


def test_saddle_refinement_converges_from_a_pixel_away():
    R = cv2.Rodrigues(np.array([0.3, 0.2, 0.1]))[0]
    t = np.array([0.0, 0.0, 550.0]) - R @ BOARD.corners_mm().mean(axis=0)
    img = raster_chessboard(BOARD, K, R, t)
    truth = project(BOARD.corners_mm(), K, R, t)
    start = truth + np.random.default_rng(3).uniform(-1, 1, truth.shape)
    refined = refine_saddle(img, start, half_window=6)
    assert np.sqrt(np.mean(np.sum((refined - truth) ** 2, axis=1))) < 0.05


def test_image_without_a_board_gives_none():
    rng = np.random.default_rng(0)
    assert find_chessboard_corners(rng.integers(0, 255, (480, 640), dtype=np.uint8), 9, 6) is None
    assert find_chessboard_corners(np.full((480, 640), 128, np.uint8), 9, 6) is None
