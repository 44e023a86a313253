"""A branched arm's kinematics and its twin's statics (issue 63): the estimators' chain of a
torso carrying two arms against MuJoCo's tree of bodies (points of each tool, the Jacobian,
gravity torques with a follower), the twin's settled postures against MuJoCo's stepping, the
links' lateral flex model against the twin's segmented link, and the serial arm as the tree's
special case."""

from pathlib import Path

import numpy as np
import pytest

from calibench.estimators.arm.kinematics import gravity_torques, jacobian, n_params, point
from calibench.estimators.arm.point import PointProblem, PointState
from calibench.scenarios.arm_cmm.arms import chain_of
from calibench.scenes.arm_cmm import arm_from_table, load_arm
from calibench.scenes.arm_mjcf import build_mjcf
from calibench.sim.arm_cmm import ArmSim, ArmTruth
from tests.arm_torso import torso_toml


@pytest.fixture(scope="module")
def torso(tmp_path_factory):
    path = tmp_path_factory.mktemp("torso") / "arm.toml"
    path.write_text(torso_toml())
    return load_arm(str(path))


def _errors(arm, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    N = arm.n_joints
    per = np.c_[rng.normal(0, 0.2, (N, 2)), rng.normal(0, 2e-3, (N, 3))]
    return np.r_[per.ravel(), rng.normal(0, 0.3, 3 * arm.n_tools)]


def test_the_tree_is_read_as_described(torso):
    """Parents, the follower's row of coefficients, two tools on the forearms; the pairs of
    parallel axes are a joint and its parent's."""
    assert torso.parent == (0, 1, 2, 3, 4, 5, 3, 7, 8)
    assert torso.followers() == [3]
    assert torso.follows[2] == (0.25, 0.5, 0, 0, 0, 0, 0, 0, 0)
    assert torso.tools_joint == (6, 9) and torso.n_tools == 2
    assert torso.parallel_pairs() == [(2, 3), (3, 4), (5, 6), (3, 7), (8, 9)]
    q = np.radians([[10.0, 20.0, 99.0, 0, 0, 0, 0, 0, 0]])
    assert np.degrees(torso.joint_angles(q))[0, 2] == pytest.approx(0.25 * 10 + 0.5 * 20)


def test_chain_is_mujocos_tree_with_errors(torso):
    """Each row's tool point of the estimators' chain (a follower's angle from its readings)
    against MuJoCo's bodies built from the same description, as-built errors in their frames:
    1e-9 mm."""
    delta = _errors(torso, 0)
    sim = ArmSim(torso, ArmTruth(delta=tuple(delta)))
    rng = np.random.default_rng(0)
    q = rng.uniform(-np.pi, np.pi, (40, torso.n_joints))
    tool = rng.integers(0, 2, 40)
    got = point(chain_of(torso), q, delta, tool)
    np.testing.assert_allclose(got, sim.point_mm(q, tool), rtol=0, atol=1e-9)


def test_tree_jacobian_matches_central_differences(torso):
    """The analytic Jacobian of each row's tool (zero for the other arm's joints and tool)
    against central differences."""
    chain = chain_of(torso)
    rng = np.random.default_rng(1)
    q = rng.uniform(-3, 3, (8, torso.n_joints))
    tool = np.tile([0, 1], 4)
    delta = rng.normal(0, 1e-2, n_params(torso.n_joints, 2))
    J = jacobian(chain, q, delta, tool=tool)
    h = 1e-6
    for k in range(len(delta)):
        e = np.zeros_like(delta)
        e[k] = h
        fd = (point(chain, q, delta + e, tool) - point(chain, q, delta - e, tool)) / (2 * h)
        np.testing.assert_allclose(J[:, :, k], fd, atol=1e-6)
    # the left arm's shoulder does not move the right tool
    assert not J[1::2, :, 5 * 3 : 5 * 6].any()


def test_tree_gravity_torques_are_mujocos_inverse_dynamics(torso):
    """A shared joint carries both arms: the chain's torques on every joint (the follower's too)
    against MuJoCo's recursive Newton-Euler on the twin, to 1e-9 of their size."""
    delta = _errors(torso, 2)
    sim = ArmSim(torso, ArmTruth(delta=tuple(delta)))
    q = np.random.default_rng(2).uniform(-np.pi, np.pi, (25, torso.n_joints))
    mj = sim.gravity_torques(q)
    assert np.abs(mj).max() > 50.0
    np.testing.assert_allclose(
        gravity_torques(chain_of(torso), q, delta), mj, rtol=0, atol=1e-9 * np.abs(mj).max()
    )


def test_the_twins_statics_are_mujocos_rest(torso):
    """Where the twin settles (each joint's spring holding the torque it carries, a follower's
    load carried to the joints it follows, the chest's flex hinges holding theirs) is where
    MuJoCo's stepped model comes to rest: every joint and flex hinge to 1e-9 rad; the follower
    to its equality constraint's softness (MuJoCo holds q3 = 0.25 q1 + 0.5 q2 to some 1e-8 rad
    under load: the fixed point's follower sits on it exactly)."""
    k = (2e4, 1e5, np.inf, 4e4, 3e4, 2e4, 4e4, 3e4, 2e4)
    flex = (np.inf, np.inf, 1e5) + (np.inf,) * 6
    truth = ArmTruth(
        delta=tuple(_errors(torso, 3)), stiffness_nm_per_rad=k, flex_stiffness_nm_per_rad=flex
    )
    sim = ArmSim(torso, truth)
    q = sim.random_postures(3, np.random.default_rng(3))
    settled = sim.settled(q)
    bend = settled[:, sim._flex_at]
    assert np.abs(bend).max() > 1e-4  # the chest bends by a tenth of a milliradian and more
    f = sim._hinge[2]  # the follower's qpos
    for qm, rest in zip(q, settled):
        stepped = sim.settle_by_stepping(qm, seconds=10.0)
        assert np.abs(np.delete(stepped - rest, f)).max() < 1e-9
        held = 0.25 * stepped[sim._hinge[0]] + 0.5 * stepped[sim._hinge[1]]
        soft = abs(stepped[f] - held)  # the constraint's violation where MuJoCo rests
        assert soft < 1e-7 and abs(stepped[f] - rest[f]) < soft + 1e-9


def test_the_flex_model_is_the_twins_segmented_link(torso):
    """The estimators' lateral flex (everything beyond the chest's middle turned by c M_perp
    about it) against the twin's chest on springs across it: the twin's points to 1 um, of a
    flex that moves them by more than 50 um."""
    k = (1e5, 2e5, np.inf, 1e5, 1e5, 1e5, 1e5, 1e5, 1e5)
    flex = (np.inf, np.inf, 1e5) + (np.inf,) * 6
    truth = ArmTruth(
        delta=(0.0,) * n_params(9, 2), stiffness_nm_per_rad=k, flex_stiffness_nm_per_rad=flex
    )
    sim = ArmSim(torso, truth)
    q = np.repeat(sim.random_postures(20, np.random.default_rng(1)), 2, axis=0)
    tool = np.tile([0, 1], 20)
    twin = sim.probe_mm(q, tool)
    joints = [1, 2, 4, 5, 6, 7, 8, 9]
    prob = PointProblem(
        chain_of(torso), q, twin, compliance_joints=joints, flex_links=[3], tool=tool
    )
    c = 1 / np.asarray(k)[np.asarray(joints) - 1]

    def model(flex_c: float) -> np.ndarray:
        s = PointState(np.zeros(prob.nk), np.r_[c, flex_c], np.eye(3)[None], np.zeros((1, 3)))
        return prob.model(s)

    assert np.abs(model(1e-5) - twin).max() < 1e-3
    assert np.abs(model(0.0) - twin).max() > 0.05


def test_a_serial_arm_is_the_trees_special_case(tmp_path):
    """The seed's arm written as a tree (each joint's parent, its tool a [[tool]] on the last
    joint) reads as the same description: the same chain, the same MJCF, byte for byte."""
    plain = load_arm("arm-cmm")
    joints = Path(plain.source).read_text().split("[[joint]]")
    tree = joints[0] + "".join(
        f"[[joint]]\nparent = {i}\n{j}" for i, j in enumerate(joints[1:])
    ).replace("[tool]", "[[tool]]\nparent = 6")
    (tmp_path / "tree.toml").write_text(tree)
    again = load_arm(str(tmp_path / "tree.toml"))
    assert dataclasses_equal(plain, again)
    assert build_mjcf(plain) == build_mjcf(again)
    assert not again.branched
    assert arm_from_table({"name": "x", "convention": "dh", "joint": [
        {"a_mm": 100.0, "d_mm": 0.0, "alpha_deg": 0.0}]}).parent is None  # fmt: skip


def dataclasses_equal(a, b) -> bool:
    """Two descriptions alike in every field but the file they were read from."""
    import dataclasses

    return dataclasses.replace(a, source="") == dataclasses.replace(b, source="")
