"""Every scene compiles and steps without a MuJoCo warning (mujoco_menagerie's habit)."""

import mujoco
import numpy as np
import pytest

from calibench.scenes import SCENES
from calibench.scenes.checkerboard import Chessboard


@pytest.mark.parametrize("name", sorted(SCENES))
def test_scene_compiles_and_steps_without_warnings(name):
    xml, assets = SCENES[name]()
    model = mujoco.MjModel.from_xml_string(xml, assets)
    data = mujoco.MjData(model)
    for _ in range(500):
        mujoco.mj_step(model, data)
    warnings = {mujoco.mjtWarning(i).name: data.warning[i].number for i in range(len(data.warning))
                if data.warning[i].number}
    assert warnings == {}
    assert np.isfinite(data.qpos).all()


def test_chessboard_corners_and_texture_agree():
    board = Chessboard(cols=9, rows=6, square_mm=50.0, margin_mm=25.0)
    tex = board.texture(px_per_square=64)
    assert tex.shape == (7 * 64 + 64, 10 * 64 + 64, 3)
    c = board.corners_mm()
    assert c.shape == (54, 3)
    np.testing.assert_array_equal(c[1] - c[0], [50, 0, 0])  # along a row: +x
    np.testing.assert_array_equal(c[9] - c[0], [0, 50, 0])  # next row: +y
    # the square before corner 0 is black, the one after the last corner white (cols+rows odd)
    m, s = 32, 64
    assert tex[m + s // 2, m + s // 2, 0] == 0
    assert tex[m + 6 * s + s // 2, m + 9 * s + s // 2, 0] == 255
    assert tex[0, 0, 0] == 255  # white margin


def test_texture_margin_must_be_whole_texels():
    with pytest.raises(ValueError):
        Chessboard(square_mm=50.0, margin_mm=10.0).texture(px_per_square=4)
