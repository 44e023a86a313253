"""Frames developed on worker threads (sim.frame_workers): the same results in the same order as
developed in turn, whatever the number of threads, for a toy development and for the belt
stage's rendered views (images and corners, bit for bit)."""

import threading
import time

import numpy as np
import pytest

from calibench.scenarios.belt_stage.scenario import BeltStageConfig
from calibench.scenarios.belt_stage.views import record_views
from calibench.sim.belt_stage import BeltStageSim, intrinsic_view_poses
from calibench.sim.frame_workers import IN_FLIGHT_PER_WORKER, develop_all, usable_cores


def test_results_keep_the_captures_order_and_the_capture_waits_for_the_oldest():
    """Developments that finish out of order (the early ones slowest) come back in order; no
    more than IN_FLIGHT_PER_WORKER per worker are ever captured and not yet developed."""
    captured, developed = [], []
    lock = threading.Lock()

    def captures():
        for i in range(20):
            with lock:
                assert len(captured) - len(developed) <= IN_FLIGHT_PER_WORKER * 3
                captured.append(i)
            yield i

    def develop(i):
        time.sleep(0.002 * (20 - i) % 0.013)
        with lock:
            developed.append(i)
        return i * i

    assert develop_all(captures(), develop, 3) == [i * i for i in range(20)]
    assert sorted(developed) == list(range(20))


def test_a_failed_development_is_raised_on_the_capturing_thread():
    def develop(i):
        if i == 3:
            raise ValueError("no board")
        return i

    with pytest.raises(ValueError, match="no board"):
        develop_all(range(8), develop, 2)


def test_no_workers_develops_on_this_thread():
    names = develop_all(range(3), lambda _: threading.current_thread().name, 0)
    assert names == [threading.current_thread().name] * 3


def test_usable_cores_is_at_least_one():
    assert usable_cores() >= 1


@pytest.mark.render
def test_rendered_views_are_the_same_whatever_the_threads():
    """Three tilted views and two stations rendered with the sensor's noise and blur, developed
    in turn and on two threads: the same images and corners, bit for bit (the noise is drawn
    as each view is captured, in the views' order)."""
    config = BeltStageConfig()
    g = config.geometry
    size = (g.camera.width, g.camera.height)
    sim = BeltStageSim(g, config.truth, render=True)
    try:
        poses = intrinsic_view_poses(g, 3, np.random.default_rng(5))
        steps = [("calib", R, t) for R, t in poses] + [
            ("station", 0, 0),
            ("station", 120_000, 90_000),
        ]
        runs = []
        for workers in (0, 2):
            sim.park_calib_board()
            sim.move(0, 0)
            rng = np.random.default_rng(11)
            runs.append(record_views(sim, "render", config, rng, size, steps, False, workers))
    finally:
        sim.close()
    (serial, true_0), (threaded, true_2) = runs
    assert serial.names == threaded.names and np.array_equal(true_0, true_2)
    assert np.isfinite(serial.corners_px).all()  # every view's board found: a real comparison
    assert np.array_equal(serial.corners_px, threaded.corners_px)
    assert all(np.array_equal(a, b) for a, b in zip(serial.images, threaded.images))
    assert len(serial.images) == len(steps)


@pytest.mark.render
def test_noise_drawn_while_gl_renders_is_the_noise_drawn_in_turn(monkeypatch):
    """A full frame's noise drawn on its own thread while GL renders, against the same frames
    with every draw in turn (the threshold above any frame): the same noise, frame by frame,
    and the generator left where it was, so the draws after a capture are the same too."""
    from calibench.sim import renderer

    drawn_on = []
    draw = renderer.sensor_noise

    def spy(rng, shape, noise_dn):
        drawn_on.append(threading.current_thread() is threading.main_thread())
        return draw(rng, shape, noise_dn)

    monkeypatch.setattr(renderer, "sensor_noise", spy)
    config = BeltStageConfig()
    g = config.geometry
    sim = BeltStageSim(g, config.truth, render=True)
    lens = sim.renderer
    assert lens is not None
    full = (g.camera.height, g.camera.width)
    window = (100, 80, 260, 200)  # below the threshold: drawn in turn either way
    runs = []
    try:
        sim.move(0, 0)
        for threshold in (full[0] * full[1], full[0] * full[1] + 1):  # on the thread, in turn
            monkeypatch.setattr(renderer, "NOISE_THREAD_MIN_PX", threshold)
            rng = np.random.default_rng(7)
            frames = [lens.capture(sim.data, rng, 2.0, 0.5, w) for w in (None, window, None)]
            runs.append(([f.noise for f in frames], rng.random(4)))
    finally:
        sim.close()
    assert drawn_on == [False, True, False] + [True] * 3  # where each frame's noise was drawn
    (threaded, after_t), (in_turn, after_s) = runs
    assert [n.shape for n in threaded] == [full, (120, 160), full]
    assert all(np.array_equal(a, b) for a, b in zip(threaded, in_turn))
    assert np.array_equal(after_t, after_s)
