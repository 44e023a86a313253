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


def test_vision_window_finds_the_same_circle():
    """The microscope's read-out around its circle: the detector's centre as on the full frame
    (noise off, blur on), far inside its 0.002 px noise."""
    from calibench.estimators.camera.circles import find_dark_circle
    from calibench.scenarios.vision_stage.procedure import WINDOW_MARGIN_PX
    from calibench.scenes.vision_stage import VisionStageGeometry
    from calibench.sim.vision_stage import VisionStageSim, VisionStageTruth

    g = VisionStageGeometry()
    vs = VisionStageSim(g, VisionStageTruth(), np.random.default_rng(0))
    try:
        seen = 0
        for d in np.array([[0.0, 0.0], [0.4, -0.3], [15.0, 15.0], [45.2, 29.7], [90.0, 150.0]]):
            vs.move(*(np.array(g.plate_origin_reading_mm) + d))
            full = find_dark_circle(vs.render(psf_px=0.8))
            if full is None:
                continue
            seen += 1
            centre = np.array([g.camera.cx, g.camera.cy])
            r = full.radius_px + WINDOW_MARGIN_PX
            lo = np.maximum(np.floor(full.centre - r).astype(int), 0)
            hi = np.minimum(np.ceil(full.centre + r).astype(int), [g.camera.width, g.camera.height])
            img = vs.render(psf_px=0.8, window=(lo[0], lo[1], hi[0], hi[1]))
            win = find_dark_circle(img, near=centre - lo)
            assert np.abs(win.centre + lo - full.centre).max() < 2e-4
        assert seen >= 2
    finally:
        vs.close()


def test_offscreen_full_frame_is_mujocos_renderer():
    """sim/offscreen.py makes the same calls as mujoco.Renderer: the same pixels, to the bit,
    though it allocates no shadow map where no light casts a shadow (mujoco.Renderer has the
    model's 4096 px one)."""
    import mujoco

    from calibench.sim.offscreen import Offscreen

    s = BeltStageSim(BeltStageGeometry(), BeltStageTruth(), render=False)
    try:
        s.move(120_000, 100_000)
        cam = s.model.camera("overhead").id
        w, h = 320, 240
        assert s.model.vis.quality.shadowsize == 4096 and not s.model.light_castshadow.any()
        theirs = mujoco.Renderer(s.model, h, w)
        ours = Offscreen(s.model)
        assert s.model.vis.quality.shadowsize == 4096  # the caller's model keeps its own
        try:
            theirs.update_scene(s.data, camera=cam)
            np.testing.assert_array_equal(
                ours.render(s.data, cam, mujoco.MjvOption(), w, h), theirs.render()
            )
            with pytest.raises(ValueError, match="exceeds"):
                ours.render(s.data, cam, mujoco.MjvOption(), ours.max_size[0] + 1, h)
        finally:
            ours.close()
            theirs.close()
    finally:
        s.close()


def test_a_lens_sampling_is_made_once_and_shared_read_only():
    """Every renderer of one lens samples the ideal render alike: its maps are made once per
    process (a study's trials), and no renderer can change them for the others."""
    from calibench.scenes.camera import PinholeCamera
    from calibench.sim.renderer import lens_sampling

    a = lens_sampling(PinholeCamera(), 8)
    assert lens_sampling(PinholeCamera(), 8) is a
    assert lens_sampling(PinholeCamera(k1=-0.1), 8) is not a
    with pytest.raises(ValueError, match="read-only"):
        a.cells[0, 0, 0] = 1


def test_offscreens_in_one_gl_context_render_their_own_frames():
    """Render contexts made one after another in the thread's one GL context (a study worker's
    trials): each renders its own model's frame, interleaved or after the other is closed, the
    pixels of a renderer with a GL context of its own."""
    import mujoco

    from calibench.sim.offscreen import Offscreen

    sims = [BeltStageSim(BeltStageGeometry(), BeltStageTruth(), render=False) for _ in range(2)]
    try:
        for s, x in zip(sims, (0, 200_000)):
            s.move(x, x // 2)
        cam = sims[0].model.camera("overhead").id
        w, h = 320, 240
        alone = []
        for s in sims:
            r = mujoco.Renderer(s.model, h, w)
            r.update_scene(s.data, camera=cam)
            alone.append(r.render())
            r.close()
        assert not np.array_equal(*alone)
        screens = [Offscreen(s.model) for s in sims]
        assert screens[0]._gl is screens[1]._gl
        opt = mujoco.MjvOption()
        for _ in range(2):
            for s, screen, frame in zip(sims, screens, alone):
                np.testing.assert_array_equal(screen.render(s.data, cam, opt, w, h), frame)
        screens[0].close()
        np.testing.assert_array_equal(screens[1].render(sims[1].data, cam, opt, w, h), alone[1])
        screens[1].close()
    finally:
        for s in sims:
            s.close()


def test_a_grey_scene_through_a_distorted_lens_is_sampled_as_one_channel():
    """The circle plate (a grey scene) seen through a barrel lens: the one-channel sampling of a
    grey ideal image gives three equal channels, and the area of interest is the full frame's
    crop (two bilinear sums of the same samples: a rounding flip of a grey level at most)."""
    import dataclasses

    from calibench.scenes.vision_stage import VisionStageGeometry
    from calibench.sim.vision_stage import VisionStageSim, VisionStageTruth

    g = VisionStageGeometry()
    g = dataclasses.replace(g, camera=dataclasses.replace(g.camera, k1=-0.12, k2=0.08, p1=4e-4))
    vs = VisionStageSim(g, VisionStageTruth(), np.random.default_rng(0))
    try:
        vs.move(*(np.array(g.plate_origin_reading_mm) + [0.4, -0.3]))
        full = vs.render()
        assert (full[..., 0] == full[..., 1]).all() and (full[..., 0] == full[..., 2]).all()
        assert full.min() < 64 < 192 < full.max()  # a dark circle on a light plate: not blank
        w = (100, 80, 300, 260)
        win = vs.render(window=w)
        d = np.abs(win.astype(int) - full[80:260, 100:300])
        assert d.max() <= 1 and (d > 0).mean() < 1e-3
    finally:
        vs.close()
