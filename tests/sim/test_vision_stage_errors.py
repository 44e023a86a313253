"""The vision stage's axis errors: one evaluation of the six (a move's hot path) equals each
component's own formula, to the last bit."""

import numpy as np

from calibench.sim.vision_stage import AxisErrors, Smooth


def test_the_six_errors_at_once_equal_each_components_own():
    e = AxisErrors(pos=Smooth(1e-3, 2.0, 1.5, 37.0, 0.3), straight_1=Smooth(bow=3.0),
                   roll=Smooth(amp=4e-6, period=55.0), yaw=Smooth(2e-6, 1e-5, 3e-6, 90.0, 1.0))
    names = ("pos", "straight_1", "straight_2", "roll", "pitch", "yaw")
    for u in (0.0, 12.3, 117.7, 199.9):
        own = np.array([getattr(e, n)(u, 200.0) for n in names])
        np.testing.assert_array_equal(e.at(u, 200.0), own)
