"""An area-of-interest read-out (issue 39) is the full frame's crop: the same pixels to the
rounding of one grey level, the same corners to far below the detector's noise."""

import numpy as np
import pytest

from calibench.estimators.camera.chessboard import find_chessboard_corners
from calibench.scenes.belt_stage import BeltStageGeometry
from calibench.sim.belt_stage import BeltStageSim, BeltStageTruth


@pytest.fixture(scope="module")
def sim():
    s = BeltStageSim(BeltStageGeometry(), BeltStageTruth())
    yield s
    s.close()


def _views(sim):
    """Stations at the travel's corners and middle, and a tilted calibration view."""
    for x, y in ((0, 0), (120_000, 100_000), (245_000, 230_000)):
        sim.park_calib_board()
        sim.move(x, y)
        yield False
    R = np.array([[1, 0, 0], [0, np.cos(0.4), -np.sin(0.4)], [0, np.sin(0.4), np.cos(0.4)]])
    sim.place_calib_board(R, np.array([-60.0, 40.0, 950.0]))
    yield True


def test_window_is_the_full_frames_crop(sim):
    b = sim.geometry.board
    for calib in _views(sim):
        full = sim.render(calib)
        u0, v0, u1, v1 = w = sim.board_window(calib)
        win = sim.render(calib, window=w)
        assert win.shape == (v1 - v0, u1 - u0, 3)
        d = np.abs(win.astype(int) - full[v0:v1, u0:u1])
        # two bilinear sums of the same samples in another order: a rounding flip at most
        assert d.max() <= 1 and (d > 0).mean() < 1e-3
        c_full = find_chessboard_corners(full, b.cols, b.rows)
        c_win = find_chessboard_corners(win, b.cols, b.rows) + (u0, v0)
        # the detector's own noise on these renders is 0.012 px RMS: the read-out adds far less
        assert np.abs(c_win - c_full).max() < 2e-3


def test_window_outside_the_image_is_refused(sim):
    with pytest.raises(ValueError, match="outside"):
        sim.render(window=(600, 0, 700, 100))
