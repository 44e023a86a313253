"""The Stewart twin's leg physics: a compliant leg's screw reads what the leg gave under the axial
force MuJoCo's statics put on it (the same draws of noise otherwise)."""

import dataclasses

import numpy as np

from calibench.scenarios.stewart.scenario import StewartConfig
from calibench.sim.stewart import StewartSim, StewartTruth, stewart_poses


def test_compliant_legs_read_their_axial_force_times_compliance():
    g = StewartConfig().geometry
    c = np.array([0.02, 0.03, 0.04, 0.05, 0.03, 0.02])
    soft = dataclasses.replace(StewartTruth(), leg_compliance_um_per_n=tuple(c), payload_n=800.0)
    rigid_sim = StewartSim(g, StewartTruth(), np.random.default_rng(3))
    soft_sim = StewartSim(g, soft, np.random.default_rng(3))
    cfg = StewartConfig()
    poses = stewart_poses(
        10, np.random.default_rng(4), cfg.geometry, cfg.translation_mm, cfg.rotation_deg
    )
    for R, t in poses:
        rigid_sim.set_pose(R, t)
        soft_sim.set_pose(R, t)
        force = rigid_sim.leg_forces_n(R, t, 800.0)
        rigid_sim.set_pose(R, t)
        # 1e-9 mm: the same noise draws; what differs is c f
        np.testing.assert_allclose(
            soft_sim.readings_mm() - rigid_sim.readings_mm(), c * 1e-3 * force, atol=1e-9
        )
    assert np.max(np.abs(c * force)) > 5  # um: the payload loads the legs, the check is not vacuous
