"""The arm's simulated laser tracker (sim.arm_cmm): its range noise is the a + b L it states."""

import numpy as np

from calibench.sim.arm_cmm import ArmSim, ArmTruth


def test_range_scatter_grows_with_distance_as_a_plus_b_l():
    """The same posture measured 20 000 times from a tracker 1 m and 6 m away: the range's
    scatter is a + b L (5 um + 1 um/m, so 6 and 11 um), each std known to 1/sqrt(2 n) = 0.5 %;
    within 3 % is six of those. Without its distance term both would be 5 um."""
    n, a, b = 20_000, 5.0, 1.0
    q = np.zeros((n, 6))
    for pos, want_m in (((600.0, -300.0, 350.0), 1.0), ((5400.0, -2700.0, 350.0), 6.0)):
        sim = ArmSim("arm-cmm", ArmTruth(tracker_pos_mm=pos, range_noise_um=(a, b)))
        exact = sim.tracker(q[:1], None)[0, 0]
        assert abs(exact / 1000 - want_m) < 0.5  # the distance the test is about, roughly
        scatter_um = np.std(sim.tracker(q, np.random.default_rng(3))[:, 0] - exact) * 1000
        assert abs(scatter_um / (a + b * exact / 1000) - 1) < 0.03, (exact, scatter_um)
