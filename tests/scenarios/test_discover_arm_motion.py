"""An arm joint's errors that follow its motion or a moment, not its angle (issue 61): lost
motion in a joint's drive, and a joint's reading that steps once (a knock, a slipped encoder).
The arm is MuJoCo's (the seed's 6-joint arm, its twin's kinematics); the encoders read the
motors, the links lag them, and a 10 um reference measures the probe."""

import numpy as np
import pytest

from calibench.recordings.records import ArmRecording
from calibench.scenarios.arm_cmm.discovery import discover_arm
from calibench.scenes.arm_cmm import load_arm
from calibench.sim.arm_cmm import ArmSim, ArmTruth

NOISE_MM = 0.010
POSTURES = 300
SPACING_S = 12.0


@pytest.fixture(scope="module")
def arm():
    description = load_arm("arm-cmm")
    truth = ArmTruth()
    return description, truth, ArmSim(description, truth)


def _recording(arm, seed: int, reading_error) -> ArmRecording:
    """POSTURES random postures one SPACING_S apart; the links at ``q``, the encoders reading
    ``q + reading_error(q, t)``; the probe measured in the reference's frame."""
    _, truth, sim = arm
    rng = np.random.default_rng(seed)
    q = sim.random_postures(POSTURES, rng)
    t = np.arange(POSTURES) * SPACING_S
    R, p = truth.tracker2base()
    xyz = (sim.probe_mm(q) - p) @ R + rng.normal(0, NOISE_MM, (POSTURES, 3))
    q_read = q + reading_error(q, t) + rng.normal(0, truth.encoder_noise_urad * 1e-6, q.shape)
    return ArmRecording(q_read, xyz, t)


def _named(out: dict) -> dict:
    return {
        (e["name"], e["params"].get("joint")): e for e in out["effects"] if e["name"] != "geometry"
    }


def test_a_joint_s_lost_motion_is_named_backlash_not_an_eccentricity(arm):
    """Joint 3's link lags its motor by 150 urad in the direction it last turned (300 urad of
    lost motion): named ``backlash`` on joint 3 within 3 of its standard error, and not taken
    for an encoder's eccentricity or a gear harmonic of that joint."""
    b = 300e-6

    def lost(q, t):
        turned = np.sign(np.diff(q[:, 2], prepend=q[0, 2]))
        err = np.zeros_like(q)
        err[:, 2] = b / 2 * turned
        return err

    out, _ = discover_arm(_recording(arm, 11, lost), 0, arm="arm-cmm")
    named = _named(out)
    e = named[("backlash", 3)]
    assert abs(e["params"]["urad"] - b * 1e6) < 3 * e["stderr"]["urad"], e
    assert not {("encoder_eccentricity", 3), ("transmission", 3)} & set(named), named


def test_a_joint_reading_that_steps_once_is_named_with_its_moment(arm):
    """Joint 2's reading jumps by 200 urad at 1800 s and stays: named ``step`` on joint 2, its
    size within 3 of its standard error and its moment within the postures either side."""
    s, at = 200e-6, 1800.0

    def knock(q, t):
        err = np.zeros_like(q)
        err[:, 1] = s * (t >= at)
        return err

    out, _ = discover_arm(_recording(arm, 12, knock), 0, arm="arm-cmm")
    e = _named(out)[("step", 2)]
    assert abs(e["params"]["size_urad"] - s * 1e6) < 3 * e["stderr"]["size_urad"], e
    assert abs(e["params"]["at_s"] - at) <= SPACING_S, e
    assert any(d["driver"] == "t_s" for d in out["located"]), out["located"]
