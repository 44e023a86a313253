"""The vision stage's axis errors: one evaluation of both axes' twelve (a move's hot path) equals
each component's own formula, to the last bit."""

import numpy as np

from calibench.sim.vision_stage import AxisErrors, Smooth, axes_errors


def test_both_axes_errors_at_once_equal_each_components_own():
    x = AxisErrors(
        pos=Smooth(1e-3, 2.0, 1.5, 37.0, 0.3),
        straight_1=Smooth(bow=3.0),
        roll=Smooth(amp=4e-6, period=55.0),
        yaw=Smooth(2e-6, 1e-5, 3e-6, 90.0, 1.0),
    )
    y = AxisErrors(
        pos=Smooth(-2e-3, 1.0),
        pitch=Smooth(7e-6, 2e-5, 1e-6, 40.0, -0.5),
        straight_2=Smooth(amp=0.4),
    )
    names = ("pos", "straight_1", "straight_2", "roll", "pitch", "yaw")
    travel = np.array([200.0, 150.0])
    for u in ((0.0, 0.0), (12.3, 140.1), (117.7, 3.3), (199.9, 150.0)):
        own = np.array(
            [[getattr(e, n)(ui, tr) for n in names] for e, ui, tr in zip((x, y), u, travel)]
        )
        np.testing.assert_array_equal(axes_errors(x, y, np.array(u), travel), own)


def test_a_path_of_moves_at_once_equals_the_moves_one_by_one():
    """The interferometer's runs are made as one path (the moves' errors and every random draw
    in one batch): the readings, the draws consumed and the machine's state afterwards equal
    those of the single moves and readings, to the last bit, with drive errors on too."""
    import dataclasses

    from calibench.scenes.vision_stage import VisionStageGeometry
    from calibench.sim.stage_drive import DriveErrors
    from calibench.sim.vision_stage import VisionStageSim, VisionStageTruth

    truth = dataclasses.replace(
        VisionStageTruth(),
        drive_x=DriveErrors(reversal_at_home_um=-1.5, periodic_um=0.4, period_mm=21.0),
    )
    rng = np.random.default_rng(7)
    targets = np.c_[rng.uniform(5, 150, 40), rng.uniform(5, 100, 40)]
    targets[5:9, 1] = targets[4, 1]  # an axis that stands still keeps its direction
    read = rng.random(40) < 0.7
    sims = [
        VisionStageSim(VisionStageGeometry(), truth, np.random.default_rng(3), render=False)
        for _ in range(2)
    ]
    for sim in sims:
        sim.move(60.0, 40.0)
    one_by_one = []
    for t, r in zip(targets, read):
        sims[0].move(*t)
        if r:
            one_by_one.append(sims[0].interferometer_mm(1, 0.05))
    at_once = sims[1].move_path(targets, read, 1, 0.05)
    np.testing.assert_array_equal(at_once, one_by_one)
    np.testing.assert_array_equal(sims[1].data.qpos, sims[0].data.qpos)
    np.testing.assert_array_equal(sims[1].reading_mm, sims[0].reading_mm)
    assert sims[1].rng.random() == sims[0].rng.random()
    sims[0].move(10.0, 10.0)  # the next move's direction: from the state each path left
    sims[1].move(10.0, 10.0)
    np.testing.assert_array_equal(sims[1].data.qpos, sims[0].data.qpos)
