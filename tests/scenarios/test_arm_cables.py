"""A cable-driven 7-joint arm with a differential wrist (docs/formats.md, "Arm descriptions":
``[transmission]``): the twin's cables are MuJoCo tendons, the recordings come from its statics, and
``fit`` and ``discover`` are checked against the stiffness the twin was given.

The arm: joints 2 and 4 are each driven by a cable of their own (a cable that drives one joint
alone stretches as that joint's compliance would); motors 6 and 7 drive the wrist's joints 6
and 7 through a differential (q6 = (m6 + m7) / 2, q7 = (m6 - m7) / 2), and motor 6's cable is
soft. Its stretch turns both wrist joints together, which no joint's own compliance does.
"""

import json

import mujoco
import numpy as np
import pytest

from calibench.estimators.rotations import rotvec_to_matrix
from calibench.recordings import ArmRecording
from calibench.scenarios.cli import main
from calibench.sim.arm_cmm import ArmSim, ArmTruth

NOISE_MM = 0.01  # the tracker's 1-sigma per coordinate
CABLES = (np.inf, 2.0e4, np.inf, 8.0e3, np.inf, 1200.0, np.inf)  # N m / rad per motor

# a_mm, d_mm, alpha_deg, range_deg, mass_kg, com_mm per joint: a 7-joint arm of a lightweight
# research arm's proportions
JOINTS = [
    (0.0, 340.0, -90.0, (-170, 170), 4.0, (0.0, -30.0, 0.0)),
    (0.0, 0.0, 90.0, (-100, 100), 4.0, (0.0, 0.0, 60.0)),
    (0.0, 400.0, 90.0, (-170, 170), 3.0, (0.0, 30.0, 0.0)),
    (0.0, 0.0, -90.0, (-120, 120), 2.5, (0.0, 0.0, 50.0)),
    (0.0, 400.0, -90.0, (-170, 170), 1.5, (0.0, -20.0, 0.0)),
    (0.0, 0.0, 90.0, (-120, 120), 1.0, (0.0, 0.0, 20.0)),
    (0.0, 126.0, 0.0, (-170, 170), 0.5, (0.0, 0.0, -20.0)),
]
COUPLING = np.eye(7)
COUPLING[5:, 5:] = [[0.5, 0.5], [0.5, -0.5]]


def arm_toml(cables=None) -> str:
    """The arm's ARM.toml; ``cables`` (7,) N m / rad or None (the user's file: no stiffness)."""
    text = 'name = "cable7"\nconvention = "dh"\n'
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


def _record(tmp, cables, n=800, seed=3) -> None:
    """A tracker recording of the twin with ``cables`` (in an instrument frame of its own)."""
    (tmp / "truth.toml").write_text(arm_toml(cables))
    (tmp / "arm.toml").write_text(arm_toml())
    sim = ArmSim(str(tmp / "truth.toml"))
    rng = np.random.default_rng(seed)
    q = sim.random_postures(n, rng)
    R, t = rotvec_to_matrix(np.array([0.01, 0.02, 2.0])), np.array([2000.0, -1500.0, 200.0])
    noise = rng.normal(0, NOISE_MM, (n, 3))
    ArmRecording(q, sim.probe_mm(q) @ R.T + t + noise).to_csv(tmp / "r.csv")


@pytest.fixture(scope="module")
def cabled(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("cabled")
    _record(tmp, CABLES)
    return tmp


def test_the_twins_cables_hold_gravity_in_mujocos_statics(tmp_path):
    """At the posture the simulation settles in, MuJoCo's own tendon springs (the cables,
    stretched from the motors' angles through the inverse coupling) balance its gravity on
    every motor that has a cable: the equilibrium is MuJoCo's, not the estimators' formula."""
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
        net = COUPLING.T @ (sim.data.qfrc_passive - sim.data.qfrc_bias)  # at the motors, N m
        worst = max(worst, np.abs(net[soft]).max())
        sag = max(sag, np.abs(ql - qm).max())
    assert sag > 1e-3  # the cables do stretch (a milliradian and more)
    assert worst < 1e-9  # N m: the fixed point's 1e-13 rad times a stiffness of 2e4


def test_a_cable_that_drives_one_joint_is_that_joints_compliance(tmp_path):
    """Without a coupling, motor j's cable and joint j's own spring are the same physics: the
    twin settles alike to the last bit of the fixed point's tolerance."""
    (tmp_path / "a.toml").write_text(
        arm_toml(CABLES).split("coupling")[0]
        + "cable_stiffness_nm_per_rad = [inf, 2e4, inf, 8e3, inf, 1200, inf]\n"
    )
    cable = ArmSim(str(tmp_path / "a.toml"))
    joint = ArmSim(
        str(tmp_path / "a.toml"),
        ArmTruth(stiffness_nm_per_rad=CABLES, cable_stiffness_nm_per_rad=(np.inf,) * 7),
    )
    q = cable.random_postures(10, np.random.default_rng(2))
    np.testing.assert_allclose(cable.link_angles(q), joint.link_angles(q), rtol=0, atol=1e-12)


def test_fit_recovers_each_cables_stiffness_through_the_coupling(cabled):
    """``fit --model physics`` on the arm's file (its coupling, no stiffness) estimates each
    loaded motor's cable compliance; each is within 3 standard errors of the twin's, the rigid
    cables' too, and the held-out rows come down to the tracker's noise."""
    out = cabled / "fit"
    argv = ["fit", "arm-cmm", str(cabled / "r.csv"), "--arm", str(cabled / "arm.toml")]
    assert main(argv + ["--holdout", "0.3", "--out", str(out)]) == 0
    fit = json.loads((out / "fit.json").read_text())
    got = {p["name"]: p for p in fit["parameters"] if p["name"].startswith("cable_compliance")}
    assert {"cable_compliance2", "cable_compliance4", "cable_compliance6"} <= set(got)
    assert not any(p["name"].startswith("compliance") for p in fit["parameters"])
    for name, p in got.items():
        truth = 1e6 / CABLES[int(name.removeprefix("cable_compliance")) - 1]
        assert abs(p["estimate"] - truth) < 3 * p["std"], (name, p, truth)
    # the soft wrist cable's stiffness itself, to a per cent
    assert 1e6 / got["cable_compliance6"]["estimate"] == pytest.approx(CABLES[5], rel=0.03)
    # 3-D error of a point with 10 um per coordinate: about 16 um on average
    assert fit["holdout"]["r.csv"]["mean_mm"] < 2 * NOISE_MM


def test_discover_names_the_cable_not_a_joint_and_agrees_with_fit(cabled):
    """``discover`` offers each joint's compliance and each differential motor's cable on the
    same postures: it accepts motor 6's cable (whose stretch turns joints 6 and 7 together), not
    joint 6's or joint 7's compliance; it says that the cables of motors 2 and 4, which drive one
    joint each, cannot be told from those joints' compliance; and every compliance fit finds
    beyond 5 standard errors scores in discover too, at the same value within 3 standard errors
    of the two."""
    out = cabled / "discover"
    argv = ["discover", "arm-cmm", str(cabled / "r.csv"), "--arm", str(cabled / "arm.toml")]
    assert main(argv + ["--out", str(out)]) == 0
    disc = json.loads((out / "discovery.json").read_text())
    effects = {
        (e["name"], e["params"].get("motor", e["params"].get("joint"))): e
        for e in disc["effects"]
        if e["name"] != "geometry"
    }
    assert ("cable_compliance", 6) in effects
    assert ("joint_compliance", 6) not in effects and ("joint_compliance", 7) not in effects
    assert set(effects) == {
        ("joint_compliance", 2),
        ("joint_compliance", 4),
        ("cable_compliance", 6),
    }
    alike = {c["with"] for c in disc["confounded"]}
    assert {"cable_compliance:motor2", "cable_compliance:motor4"} <= alike
    assert disc["fit"]["cv_rms_final"] < 1.3 * NOISE_MM * np.sqrt(3)
    fit_out = cabled / "fit-agree"
    argv = ["fit", "arm-cmm", str(cabled / "r.csv"), "--arm", str(cabled / "arm.toml")]
    assert main(argv + ["--out", str(fit_out)]) == 0
    fit = json.loads((fit_out / "fit.json").read_text())
    compared = 0
    for p in fit["parameters"]:
        if not p["name"].startswith("cable_compliance") or abs(p["estimate"]) < 5 * p["std"]:
            continue
        m = int(p["name"].removeprefix("cable_compliance"))
        e = effects.get(("cable_compliance", m)) or effects[("joint_compliance", m)]
        both = np.hypot(p["std"], e["stderr"]["urad_per_nm"])
        assert abs(e["params"]["urad_per_nm"] - p["estimate"]) < 3 * both, (p, e)
        compared += 1
    assert compared >= 1  # motor 6's cable at least: the loop compared something


def test_discover_finds_nothing_on_rigid_cables(tmp_path):
    """The null: the same arm with rigid cables (and its kinematic errors): no compliance of
    either kind, nothing beyond the geometry."""
    _record(tmp_path, (np.inf,) * 7, n=400, seed=4)
    out = tmp_path / "discover"
    argv = ["discover", "arm-cmm", str(tmp_path / "r.csv"), "--arm", str(tmp_path / "arm.toml")]
    assert main(argv + ["--out", str(out)]) == 0
    disc = json.loads((out / "discovery.json").read_text())
    assert [e["name"] for e in disc["effects"]] == ["geometry"]


def test_fit_takes_the_effects_discover_found_on_a_cabled_arm(cabled):
    """A discovery.json that names a cable is an arm's effects file: fit --effects takes it (the
    cable is the physics model's own parameter) and scores it as in-sample (it chose on them)."""
    disc = cabled / "discover-for-fit"
    rec, arm = str(cabled / "r.csv"), str(cabled / "arm.toml")
    assert main(["discover", "arm-cmm", rec, "--arm", arm, "--out", str(disc)]) == 0
    out = cabled / "fit-effects"
    argv = ["fit", "arm-cmm", rec, "--arm", arm, "--holdout", "0.3", "--out", str(out)]
    assert main(argv + ["--effects", str(disc / "discovery.json")]) == 0
    fit = json.loads((out / "fit.json").read_text())
    assert "r.csv" in fit["in_sample"] and "cable_compliance6" in {
        p["name"] for p in fit["parameters"]
    }
