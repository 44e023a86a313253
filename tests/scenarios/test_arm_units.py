"""A transmission's motor angles in any unit give the same calibration (issue 63).

A cable-driven 7-joint arm with real reductions (14 to 42 to one, motor angles in motor radians)
and two asymmetric differentials, the shoulder's and the wrist's: the twin's cables are MuJoCo
tendons and its recordings come from MuJoCo's statics (``tests/scenarios/test_arm_cables.py``'s
arm, geared). A user may write each motor's angle in any unit: motor m's angle in units s_m
times smaller scales its coupling column by 1 / s_m and its compliance at the motor by s_m^2. The
predictions, the parameters dropped and the compliance seen at the joints must not change, for
s_m from 1e-3 to 1e3.
"""

import json

import numpy as np
import pytest

from calibench.estimators.rotations import rotvec_to_matrix
from calibench.recordings import ArmRecording
from calibench.scenarios.cli import main
from calibench.sim.arm_cmm import ArmSim
from tests.scenarios.test_arm_cables import JOINTS

NOISE_MM = 0.01
# joint angles = COUPLING @ motor angles (motor radians): a reduction on each motor, the
# shoulder's joints 2-3 and the wrist's 5-6 each driven by a differential of two motors whose
# rows are not each other's transpose
COUPLING = np.zeros((7, 7))
COUPLING[0, 0] = 1 / 42.0
COUPLING[1, 1:3] = [-1 / 56.5, 1 / 56.5]
COUPLING[2, 1:3] = [-1 / 95.0, -1 / 95.0]
COUPLING[3, 3] = 1 / 18.0
COUPLING[4, 4:6] = [1 / 19.4, 1 / 19.4]
COUPLING[5, 4:6] = [-1 / 27.0, 1 / 27.0]
COUPLING[6, 6] = 1 / 14.93
# the cables' stiffness seen at the joints they drive (N m / rad), converted to the motor's
# (k_motor = k_joint |column|^2): soft cables on the shoulder's first motor, the elbow and the
# wrist's first motor
JOINT_SIDE_STIFFNESS = np.array([np.inf, 1.5e4, np.inf, 6.0e3, 1.5e3, np.inf, np.inf])
CABLES = JOINT_SIDE_STIFFNESS * np.sum(COUPLING**2, axis=0)
# each motor's unit: s_m motor units to the radian
UNITS = np.array([1e-3, 1e3, 10.0, 0.01, 1e2, 1.0, 0.1])


def geared_toml(coupling: np.ndarray, cables=None) -> str:
    """The arm's ARM.toml with ``coupling`` (7, 7) and, for the twin, its ``cables`` (7,)."""
    text = 'name = "geared7"\nconvention = "dh"\n'
    for a, d, alpha, (lo, hi), m, com in JOINTS:
        text += (
            f"[[joint]]\na_mm = {a}\nd_mm = {d}\nalpha_deg = {alpha}\n"
            f"range_deg = [{lo}.0, {hi}.0]\nmass_kg = {m}\ncom_mm = {list(com)}\n"
        )
    text += "[tool]\noffset_mm = [40.0, 10.0, 80.0]\nmass_kg = 1.0\n[transmission]\n"
    text += f"coupling = {[[float(f'{v:.17g}') for v in r] for r in coupling.tolist()]}\n"
    if cables is not None:
        text += f"cable_stiffness_nm_per_rad = [{', '.join(f'{k:.17g}' for k in cables)}]\n"
    return text


@pytest.fixture(scope="module")
def geared(tmp_path_factory):
    """A recording of the twin, and the user's arm written in motor radians and in the odd units."""
    tmp = tmp_path_factory.mktemp("geared")
    (tmp / "truth.toml").write_text(geared_toml(COUPLING, CABLES))
    (tmp / "radians.toml").write_text(geared_toml(COUPLING))
    (tmp / "units.toml").write_text(geared_toml(COUPLING / UNITS))
    sim = ArmSim(str(tmp / "truth.toml"))
    rng = np.random.default_rng(7)
    q = sim.random_postures(600, rng)
    R, t = rotvec_to_matrix(np.array([0.02, -0.01, 1.2])), np.array([1800.0, 900.0, -300.0])
    noise = rng.normal(0, NOISE_MM, (len(q), 3))
    ArmRecording(q, sim.probe_mm(q) @ R.T + t + noise).to_csv(tmp / "r.csv")
    fits = {}
    for arm in ("radians", "units"):
        out = tmp / arm
        argv = ["fit", "arm-cmm", str(tmp / "r.csv"), "--arm", str(tmp / f"{arm}.toml")]
        assert main(argv + ["--holdout", "0.3", "--out", str(out)]) == 0
        fits[arm] = json.loads((out / "fit.json").read_text())
    return fits


def _cables(fit: dict) -> dict[int, dict]:
    return {
        int(p["name"].removeprefix("cable_compliance")): p
        for p in fit["parameters"]
        if p["name"].startswith("cable_compliance")
    }


def test_the_units_of_the_motor_angles_change_no_prediction(geared):
    a, b = geared["radians"], geared["units"]
    for figure in ("mean_mm", "rms_mm", "max_mm"):
        assert b["holdout"]["r.csv"][figure] == pytest.approx(
            a["holdout"]["r.csv"][figure], rel=1e-4
        )
    assert b["fit"]["rms_mm"] == pytest.approx(a["fit"]["rms_mm"], rel=1e-4)
    assert sorted(d["name"] for d in b["dropped"]) == sorted(d["name"] for d in a["dropped"])


def test_each_cable_is_the_same_at_the_joints_in_any_unit(geared):
    """Each cable's compliance, seen at its joints (times its column's squared norm), agrees in
    both units to a part in 1e4 of its std, and with the twin's within 3 std."""
    a, b = _cables(geared["radians"]), _cables(geared["units"])
    assert set(a) == set(b) and {2, 4, 5} <= set(a), (a, b)
    for m, p in a.items():
        q = b[m]
        # motor m's compliance in the odd unit: s_m^2 that in motor radians
        assert q["estimate"] == pytest.approx(UNITS[m - 1] ** 2 * p["estimate"], rel=1e-4), m
        assert q["std"] == pytest.approx(UNITS[m - 1] ** 2 * p["std"], rel=1e-3), m
        for k in ("estimate", "std"):  # fit.json's own figure at the joints
            assert q["at_joints"][k] == pytest.approx(p["at_joints"][k], rel=1e-3), (m, k)
        seen, truth = p["at_joints"], 1e6 / JOINT_SIDE_STIFFNESS[m - 1]
        assert abs(seen["estimate"] - truth) < 3 * seen["std"], (m, seen, truth)


def test_no_cable_is_used_below_zero(geared):
    for fit in geared.values():
        assert all(p["estimate"] >= 0 for p in _cables(fit).values()), _cables(fit)
