"""The second suite's arm effects (sim.concealed.unwritten), made by MuJoCo's physics: a
strain-wave gear whose links settle where its catalogue wind-up holds the gravity torque, with a
kinematic error that grows and shifts with that torque; a link of two segments on springs that
bends where they hold gravity."""

import mujoco
import numpy as np

from calibench.scenes.arm_cmm import load_arm
from calibench.scenes.arm_mjcf import build_mjcf
from calibench.sim.arm_cmm import ArmSim, ArmTruth
from calibench.sim.concealed.unwritten import (
    GEAR_KNEES,
    GEAR_STIFFENING,
    bent_link_points,
    harmonic_drive_angles,
)


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


def test_a_segmented_link_bends_where_its_springs_hold_gravity():
    """The second suite's bent link (sim.concealed.unwritten.bent_link_points): the segmented
    MJCF with springs too stiff to give is the rigid twin, to 1e-9 mm; with the drawn springs
    the largest bend is the drawn 100-300 urad and the tool moves by at most that angle times the
    arm's reach."""
    arm = load_arm("arm-cmm")
    sim = ArmSim(arm, ArmTruth())
    q = sim.random_postures(40, np.random.default_rng(5))
    N = arm.n_joints
    values = arm.nominal() + sim.delta[: 5 * N].reshape(N, 5)
    tool = np.asarray(arm.tool_mm) + sim.delta[5 * N :]
    stiff = mujoco.MjModel.from_xml_string(build_mjcf(arm, values, tool, bend=(3, 1e15)))
    data = mujoco.MjData(stiff)
    rigid = sim.point_mm(q)
    for i in range(len(q)):
        data.qpos[:] = 0.0
        data.qpos[[stiff.joint(f"q{k + 1}").qposadr[0] for k in range(N)]] = q[i]
        mujoco.mj_kinematics(stiff, data)
        assert np.abs(data.site_xpos[stiff.site("probe").id] * 1000 - rigid[i]).max() < 1e-9
    bent, truth = bent_link_points(sim, q, np.random.default_rng(8))
    p = truth["params"]
    moved = np.linalg.norm(bent - rigid, axis=1)
    assert 100 <= p["largest_bend_urad"] <= 300 * 1.01
    assert 0 < moved.max() <= p["largest_bend_urad"] * 1e-6 * arm.reach_mm
    # the joints whose compliance looks like it lie across the bent link, one on each side
    assert all(j != p["link"] for j in p["joint"]) and len(p["joint"]) == 2
