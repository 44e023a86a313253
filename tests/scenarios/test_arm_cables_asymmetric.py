"""A cable arm whose transmission is not symmetric: the cables that cross a joint on their way
to the next (docs/formats.md, "Arm descriptions": ``[transmission]``, joint angles = coupling @
motor angles). The symmetric differential of ``test_arm_cables.py`` equals its own transpose, so
no test there can tell a coupling applied as ``coupling.T`` (issue 63); here each check fails if
it is.

The coupling: joint 3's cable runs over joint 2's pulley (q3 = m3 - 0.4 m2: motor 2's stretch
turns joints 2 and 3, and motor 2 carries tau2 - 0.4 tau3 back), and joint 7's over joint 6's
(q7 = m7 - 0.5 m6). Transposed, motor 2's cable would turn joint 2 alone under tau2 alone, and
motor 6's joint 6 alone.
"""

import json

import mujoco
import numpy as np
import pytest

from calibench.estimators.rotations import rotvec_to_matrix
from calibench.recordings import ArmRecording
from calibench.scenarios.cli import main
from calibench.sim.arm_cmm import ArmSim
from tests.scenarios.test_arm_cables import CABLES, JOINTS, NOISE_MM

COUPLING = np.eye(7)
COUPLING[2, 1] = -0.4  # q3 = m3 - 0.4 m2
COUPLING[6, 5] = -0.5  # q7 = m7 - 0.5 m6


def arm_toml(cables=None) -> str:
    """The arm's ARM.toml with :data:`COUPLING`; ``cables`` (7,) N m / rad, or None (the user's
    file: no stiffness)."""
    text = 'name = "cable7-asymmetric"\nconvention = "dh"\n'
    for a, d, alpha, (lo, hi), m, com in JOINTS:
        text += (
            f"[[joint]]\na_mm = {a}\nd_mm = {d}\nalpha_deg = {alpha}\n"
            f"range_deg = [{lo}.0, {hi}.0]\nmass_kg = {m}\ncom_mm = {list(com)}\n"
        )
    text += "[tool]\noffset_mm = [40.0, 10.0, 80.0]\nmass_kg = 1.0\n[transmission]\n"
    text += f"coupling = {[list(r) for r in COUPLING.tolist()]}\n"
    if cables is not None:
        text += f"cable_stiffness_nm_per_rad = [{', '.join(f'{k:g}' for k in cables)}]\n"
    return text


def test_the_coupling_is_not_its_own_transpose():
    """The premise: applied transposed, the coupling moves the joints otherwise (a symmetric one
    would hide every transposition below)."""
    assert np.abs(COUPLING - COUPLING.T).max() >= 0.4


def test_the_twins_cables_hold_gravity_through_an_asymmetric_coupling(tmp_path):
    """At the posture the twin settles in (its compliance formula, coupling diag(c) coupling.T),
    MuJoCo's own tendon springs, each a motor's angle seen through the inverse coupling, balance
    gravity at every motor that has a cable: MuJoCo's statics, not the formula, are the judge.
    Either applied transposed and the imbalance is the stretch's own size (mN m at least)."""
    (tmp_path / "a.toml").write_text(arm_toml(CABLES))
    sim = ArmSim(str(tmp_path / "a.toml"))
    q_motor = sim.random_postures(20, np.random.default_rng(1))
    q_link = sim.link_angles(q_motor)
    soft = np.isfinite(CABLES)
    worst, sag = 0.0, 0.0
    for qm, ql in zip(q_motor, q_link):
        sim.cable_references(qm)
        sim.data.qpos[:], sim.data.qvel[:] = ql, 0.0
        mujoco.mj_forward(sim.model, sim.data)
        # virtual work: the motors' torques are coupling.T @ the joints'
        net = COUPLING.T @ (sim.data.qfrc_passive - sim.data.qfrc_bias)
        worst = max(worst, np.abs(net[soft]).max())
        sag = max(sag, np.abs(ql - qm).max())
    assert sag > 1e-3  # the cables do stretch (a milliradian and more)
    assert worst < 1e-9  # N m: the fixed point's 1e-13 rad times a stiffness of 2e4


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    """A tracker recording (800 postures, 10 um) of the twin with :data:`CABLES`, its instrument
    frame its own, and the user's ARM.toml (the coupling, no stiffness)."""
    tmp = tmp_path_factory.mktemp("asymmetric")
    (tmp / "truth.toml").write_text(arm_toml(CABLES))
    (tmp / "arm.toml").write_text(arm_toml())
    sim = ArmSim(str(tmp / "truth.toml"))
    rng = np.random.default_rng(3)
    q = sim.random_postures(800, rng)
    R, t = rotvec_to_matrix(np.array([0.01, 0.02, 2.0])), np.array([2000.0, -1500.0, 200.0])
    noise = rng.normal(0, NOISE_MM, (len(q), 3))
    ArmRecording(q, sim.probe_mm(q) @ R.T + t + noise).to_csv(tmp / "r.csv")
    return tmp


def test_fit_recovers_each_cable_through_an_asymmetric_coupling(recorded):
    """``fit --model physics`` on the user's file estimates each loaded motor's cable: every one
    within 3 standard errors of the twin's (the rigid ones at zero too), motor 2's and motor 6's
    stiffness to 3 %, and the held-out rows at the tracker's noise. Motor 2's stretch turns
    joints 2 and 3 under tau2 - 0.4 tau3: the column transposed turns joint 2 alone under tau2,
    which no compliance of motor 2 fits."""
    out = recorded / "fit"
    argv = ["fit", "arm-cmm", str(recorded / "r.csv"), "--arm", str(recorded / "arm.toml")]
    assert main(argv + ["--holdout", "0.3", "--out", str(out)]) == 0
    fit = json.loads((out / "fit.json").read_text())
    got = {p["name"]: p for p in fit["parameters"] if p["name"].startswith("cable_compliance")}
    assert {"cable_compliance2", "cable_compliance4", "cable_compliance6"} <= set(got), got
    for name, p in got.items():
        truth = 1e6 / CABLES[int(name.removeprefix("cable_compliance")) - 1]  # urad / N m
        assert abs(p["estimate"] - truth) < 3 * p["std"], (name, p, truth)
    for m in (2, 6):
        k = 1e6 / got[f"cable_compliance{m}"]["estimate"]
        assert k == pytest.approx(CABLES[m - 1], rel=0.03), (m, k)
    # 3-D error of a point with 10 um per coordinate: about 16 um on average
    assert fit["holdout"]["r.csv"]["mean_mm"] < 2 * NOISE_MM, fit["holdout"]
