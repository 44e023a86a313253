"""The vision stage's axis errors: one evaluation of both axes' twelve (a move's hot path) equals
each component's own formula, to the last bit."""

import numpy as np

from calibench.sim.vision_stage import AxisErrors, Smooth, axes_errors


def test_both_axes_errors_at_once_equal_each_components_own():
    x = AxisErrors(pos=Smooth(1e-3, 2.0, 1.5, 37.0, 0.3), straight_1=Smooth(bow=3.0),
                   roll=Smooth(amp=4e-6, period=55.0), yaw=Smooth(2e-6, 1e-5, 3e-6, 90.0, 1.0))
    y = AxisErrors(pos=Smooth(-2e-3, 1.0), pitch=Smooth(7e-6, 2e-5, 1e-6, 40.0, -0.5), straight_2=Smooth(amp=0.4))
    names = ("pos", "straight_1", "straight_2", "roll", "pitch", "yaw")
    travel = np.array([200.0, 150.0])
    for u in ((0.0, 0.0), (12.3, 140.1), (117.7, 3.3), (199.9, 150.0)):
        own = np.array([[getattr(e, n)(ui, tr) for n in names] for e, ui, tr in zip((x, y), u, travel)])
        np.testing.assert_array_equal(axes_errors(x, y, np.array(u), travel), own)
