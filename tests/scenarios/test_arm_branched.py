"""A branched robot (issue 63): a torso on a column carrying two arms, its chest joint coupled to
the waist and the yaw (no encoder of its own), its chest bending across under the arms' weight.

The twin (``ArmSim``) builds the tree of bodies from the description: the follower held to its
joints by an equality on a fixed tendon in the MJCF, its angle set from theirs in the statics;
the chest two segments on springs across it halfway; the joints' springs; every posture settled
where MuJoCo's gravity (its inverse dynamics) meets the springs. ``fit arm-cmm --model physics``
calibrates the shared joints once from both arms' points (one recording, a ``tool`` column) and
is checked against that truth; ``discover`` names the same physics.
"""

import json

import numpy as np
import pytest

from calibench.estimators.arm.point import PointProblem
from calibench.estimators.identification.basis import Basis, identifiable_basis
from calibench.estimators.identification.solver import identify
from calibench.estimators.rotations import rotvec_to_matrix
from calibench.recordings import ArmRecording, load_arm_csv
from calibench.scenarios.arm_cmm.arms import chain_of
from calibench.scenarios.cli import main
from calibench.scenes.arm_cmm import load_arm
from calibench.sim.arm_cmm import ArmSim, ArmTruth
from tests.arm_torso import FLEX, STIFFNESS, torso_toml

NOISE_MM = 0.01  # the tracker's 1-sigma per coordinate
POSTURES = 300  # each measured at both tools: 600 rows

# what the points cannot tell apart (the base frame, a tool's offset, a neighbour along parallel
# axes take them; the d's along the torso's and the shoulders' parallel axes 2, 3, 4 and 7 make
# two sums, one per arm, which two of them carry): the twin's errors there are zero, so every
# parameter fit keeps has its own truth to be judged by
UNTOLD = {
    "dd1", "dtheta1", "dbeta1", "dd2", "dd3", "dd4", "dd7", "dbeta4", "dd5", "da6", "dd6",
    "dalpha6", "dtheta6", "dbeta6", "dbeta7", "dd8", "da9", "dd9", "dalpha9", "dtheta9", "dbeta9",
}  # fmt: skip


def twin_errors(arm) -> np.ndarray:
    """The as-built errors (5 N + 3 T,): lengths 0.1 mm, angles 1 mrad, beta where two axes are
    parallel, the tools' offsets 0.2 mm; zero where the points cannot tell them (:data:`UNTOLD`)."""
    from calibench.estimators.arm.kinematics import param_names

    rng = np.random.default_rng(5)
    N = arm.n_joints
    per = np.c_[rng.normal(0, 0.1, (N, 2)), rng.normal(0, 1e-3, (N, 2)), np.zeros(N)]
    for p, _ in arm.parallel_pairs():
        per[p - 1, 4] = rng.normal(0, 1e-3)
    delta = np.r_[per.ravel(), rng.normal(0, 0.2, 3 * arm.n_tools)]
    names = param_names(N, arm.n_tools)
    return np.where([n in UNTOLD for n in names], 0.0, delta)


@pytest.fixture(scope="module")
def torso(tmp_path_factory):
    """The arm's file, and a tracker recording of its twin: each posture's two tools, in the
    tracker's own frame."""
    tmp = tmp_path_factory.mktemp("torso")
    (tmp / "arm.toml").write_text(torso_toml())
    arm = load_arm(str(tmp / "arm.toml"))
    delta = twin_errors(arm)
    truth = ArmTruth(
        delta=tuple(delta), stiffness_nm_per_rad=STIFFNESS, flex_stiffness_nm_per_rad=FLEX
    )
    sim = ArmSim(arm, truth)
    rng = np.random.default_rng(5)
    q = np.repeat(sim.random_postures(POSTURES, rng), 2, axis=0)
    tool = np.tile([0, 1], POSTURES)
    R, t = rotvec_to_matrix(np.array([0.01, 0.02, 2.0])), np.array([2000.0, -1500.0, 200.0])
    xyz = sim.probe_mm(q, tool) @ R.T + t + rng.normal(0, NOISE_MM, (len(q), 3))
    ArmRecording(q, xyz, tool=tool).to_csv(tmp / "r.csv")
    return tmp, arm, delta


def _truth(arm, delta: np.ndarray) -> dict[str, float]:
    """Every parameter fit may estimate, in fit.json's units: the errors (mm, urad), each loaded
    joint's compliance and the chest's flex (urad / N m; zero for a rigid joint)."""
    from calibench.estimators.arm.kinematics import param_is_angle, param_names

    names = param_names(arm.n_joints, arm.n_tools)
    out = {n: v * (1e6 if a else 1.0) for n, v, a in zip(names, delta, param_is_angle(names))}
    out |= {f"compliance{j}": 1e6 / k for j, k in enumerate(STIFFNESS, 1)}
    out |= {f"flex_compliance{j}": 1e6 / k for j, k in enumerate(FLEX, 1)}
    return out


def test_fit_recovers_the_tree_within_3_std_and_scores_both_tools(torso):
    """``fit --model physics --holdout 0.3``: one parameter set for the tree (the torso's joints
    once, from both arms' points), every parameter it fits within 3 standard errors of the twin's
    (the loaded joints' compliance and the chest's lateral flex among them), what it drops the
    parameters the points cannot tell; the held-out rows of each tool come down to the
    tracker's noise (fit.json's holdout, tool by tool)."""
    tmp, arm, delta = torso
    out = tmp / "fit"
    argv = ["fit", "arm-cmm", str(tmp / "r.csv"), "--arm", str(tmp / "arm.toml")]
    assert main(argv + ["--holdout", "0.3", "--model", "physics", "--out", str(out)]) == 0
    fit = json.loads((out / "fit.json").read_text())
    truth = _truth(arm, delta)
    z = {p["name"]: (p["estimate"] - truth[p["name"]]) / p["std"] for p in fit["parameters"]}
    assert {"compliance2", "compliance4", "compliance7", "flex_compliance3"} <= set(z)
    assert max(abs(v) for v in z.values()) < 3, {k: round(v, 2) for k, v in z.items()}
    dropped = {d["name"] for d in fit["dropped"] if d["name"].startswith("d")}
    assert dropped <= UNTOLD and len(UNTOLD - dropped) == 2  # two of the four d's kept
    assert "joint 3 follows others" in next(
        d["why"] for d in fit["dropped"] if d["name"] == "compliance3"
    )
    assert len(fit["tools_mm"]) == 2
    held = fit["holdout"]["r.csv"]
    assert set(held["tools"]) == {"1", "2"}
    for figures in held["tools"].values():
        assert figures["samples"] > 60
        # a 3-D error of 10 um per coordinate: 17 um RMS
        assert figures["rms_mm"] < 1.25 * np.sqrt(3) * NOISE_MM, held


def test_a_links_bend_is_not_a_bearings_tilt(torso):
    """The chest's lateral flex is its own parameter: fitted with it the points whiten to their
    noise; with every joint's bearing tilting under the moment across its axis instead
    (``tilt_compliance``: a turn about the joint's origin, of everything it carries), twice the
    noise is left and the shoulders' compliance is 30 % off."""
    tmp, arm, _ = torso
    rec = load_arm_csv(tmp / "r.csv", arm.n_joints, None, None, arm.follows, arm.n_tools)
    joints = [2, 4, 5, 6, 7, 8, 9]

    def whitened(**kw) -> tuple[float, dict]:
        sigma = np.full(rec.xyz_mm.shape, NOISE_MM)
        prob = PointProblem(
            chain_of(arm), rec.q_rad, rec.xyz_mm, sigma_mm=sigma, tool=rec.tool,
            compliance_joints=joints, prior=1.0, **kw,
        )  # fmt: skip
        prob.held_tool()
        start = identify(prob, Basis(np.sort(prob.always), {}))
        prob.prior = None
        basis = identifiable_basis(prob, start.state)
        prob.prior = 1.0
        ident = identify(prob, basis, start.state)
        e = (prob.y - prob.model(ident.state)) / NOISE_MM
        return float(np.sqrt(np.mean(e**2))), ident.estimate

    flexed, est = whitened(flex_links=[3])
    assert flexed < 1.1
    assert abs(est["compliance4"] * 1e6 - 25.0) < 1.0
    tilted, est = whitened(tilt_joints=list(range(1, 10)))
    assert tilted > 1.7
    assert est["compliance4"] * 1e6 > 30.0


def test_discover_names_the_compliances_and_the_flex(torso):
    """``discover arm-cmm`` on the branched arm: the geometry, joints 2, 4 and 7's compliance and
    link 3's lateral flex, each within 3 standard errors of the twin's; no other effect."""
    tmp, _, _ = torso
    out = tmp / "discover"
    argv = ["discover", "arm-cmm", str(tmp / "r.csv"), "--arm", str(tmp / "arm.toml")]
    assert main(argv + ["--out", str(out)]) == 0
    disc = json.loads((out / "discovery.json").read_text())
    found = {
        (e["name"], e["params"].get("link", e["params"].get("joint"))): e for e in disc["effects"]
    }
    want = {("joint_compliance", 2): 10.0, ("joint_compliance", 4): 25.0}
    want |= {("joint_compliance", 7): 25.0, ("link_flex", 3): 10.0}
    assert set(found) == {("geometry", None), *want}
    for key, truth in want.items():
        p, s = found[key]["params"]["urad_per_nm"], found[key]["stderr"]["urad_per_nm"]
        assert abs(p - truth) < 3 * s, (key, p, s)
