"""The second suite's strain-wave gear (sim.concealed.unwritten.harmonic_drive_angles): the links
settle where the gear's catalogue wind-up holds MuJoCo's gravity torque, with the kinematic error
that grows and shifts with that torque."""

import numpy as np

from calibench.scenes.arm_cmm import load_arm
from calibench.sim.arm_cmm import ArmSim, ArmTruth
from calibench.sim.concealed.unwritten import GEAR_KNEES, GEAR_STIFFENING, harmonic_drive_angles


def test_the_links_settle_where_the_gear_holds_gravity():
    sim = ArmSim(load_arm("arm-cmm"), ArmTruth())
    q_motor = sim.random_postures(60, np.random.default_rng(4))
    q_link, truth = harmonic_drive_angles(sim, q_motor, np.random.default_rng(7))
    p = truth["params"]
    j = p["joint"] - 1
    # the gear is on the most loaded joint; every other link stands at its motor's angle
    tau_motor = sim.gravity_torques(q_motor)
    assert j == int(np.argmax(np.abs(tau_motor).max(axis=0)))
    assert np.array_equal(np.delete(q_link, j, axis=1), np.delete(q_motor, j, axis=1))
    # at the settled posture a fresh inverse-dynamics call gives the torque the gear holds: the
    # catalogue's wind-up of it plus the loaded kinematic error is the link's angle, to 1e-10 rad
    t_max = np.abs(tau_motor[:, j]).max()
    tau = sim.gravity_torques(q_link)[:, j]
    k1, k2, k3 = p["k1_nm_per_rad"] * np.asarray(GEAR_STIFFENING)
    t1, t2 = GEAR_KNEES[0] * t_max, GEAR_KNEES[1] * t_max
    t = np.abs(tau)
    windup = np.sign(tau) * (
        np.minimum(t, t1) / k1 + np.clip(t - t1, 0, t2 - t1) / k2 + np.maximum(t - t2, 0) / k3
    )
    load = tau / t_max
    kinematic = (
        p["amplitude_urad"]
        * 1e-6
        * (1 + 0.8 * np.abs(load))
        * np.sin(p["harmonic"] * q_motor[:, j] + p["phase_rad"] + 0.5 * load)
    )
    np.testing.assert_allclose(q_link[:, j] - q_motor[:, j], windup + kinematic, atol=1e-10)
    # the drawn wind-up is the motor postures' largest torque's; the settled postures' torques
    # differ from those by the sag's lever, far under a percent
    assert abs(np.abs(windup).max() * 1e6 - p["windup_urad"]) < 0.01 * p["windup_urad"]
    # the postures load the gear in all three of its segments
    assert t.min() < t1 and t.max() > t2
