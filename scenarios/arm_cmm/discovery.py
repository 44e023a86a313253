"""The arm's discovery plug-in (arm-cmm: the seed's arm, a UR10, any serial arm of an ARM.toml).

The scene model: MuJoCo's nominal arm replays the encoder readings; each recording's
base-to-instrument frame and the tool point are registered with the data (as a user would). The
chain's geometry is solved first (nonlinear, as ``fit`` does) and every candidate's column is
taken there: the geometry itself, each joint's compliance under the twin's gravity torques
(MuJoCo's inverse dynamics), encoder eccentricity, transmission harmonics (one phase, or one per
recording), thermal growth, then a table over a joint's angle for what none of them explains.
Folds: five contiguous blocks of postures (of each recording). The twin: the chain's errors
(``ArmTruth.delta``) and each joint's stiffness from the compliance found.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any, cast

import numpy as np

from calibench.estimators.arm.terms import directions
from calibench.estimators.discovery.arm import ArmDrivers
from calibench.estimators.discovery.motion import last_direction
from calibench.estimators.discovery.noise import Noise
from calibench.estimators.discovery.rivals import ties
from calibench.estimators.discovery.select import prune, select
from calibench.scenarios.arm_cmm import NAME
from calibench.scenarios.arm_cmm.discovery_candidates import add_joint_table, arm_candidates
from calibench.scenarios.arm_cmm.discovery_compliance import link_flex_columns
from calibench.scenarios.arm_cmm.discovery_rows import arm_floor, residual_signal, usable_rows
from calibench.scenarios.arm_cmm.discovery_sessions import (
    carried_to_sessions,
    say_belonging,
    shared_unless_sessions_differ,
)
from calibench.scenarios.arm_cmm.discovery_words import arm_confounds, locate_arm
from calibench.scenarios.discover.fresh import structure
from calibench.scenarios.discover.report import (
    Findings,
    describe_effects,
    discovery_json,
    judged,
    named_only,
)
from calibench.scenarios.report import BadInput
from calibench.scenes.arm_cmm import DEFAULT_ARM


def arm_drivers(
    arm,
    q_rad: np.ndarray,
    temp_c=None,
    t_s=None,
    truth=None,
    delta: np.ndarray | None = None,
    tool: np.ndarray | None = None,
) -> tuple[dict[str, Any], np.ndarray]:
    """What the arm's candidates need, and the twin's tool points: MuJoCo's nominal (rigid) arm
    at the readings (n, 3) mm, its gravity torques (MuJoCo's inverse dynamics) when the arm has
    masses, the chain's Jacobians, the twin's chain errors. ``truth``: a twin updated by
    ``discover --twin`` (its geometry, and its joints' stiffness: the links then settle under
    gravity in MuJoCo).
    ``delta``: the chain's errors (5 N + 3 T,) at which the Jacobians, the points and the
    flange are taken (the drawing's chain if None). ``tool``: each row's tool (n,) on a branched
    arm (0-based; None: the first): its point, and its joints' turns on the readings (a joint's
    turn moves the joints that follow it; ``Jq`` and ``tau`` are the readings')."""
    from calibench.estimators.arm.kinematics import in_readings, jacobian, pose, theta_index
    from calibench.scenarios.arm_cmm.arms import chain_of
    from calibench.sim.arm_cmm import ArmSim, ArmTruth

    N, T = arm.n_joints, arm.n_tools
    twin = ArmSim(arm, truth if truth is not None else ArmTruth(delta=(0.0,) * (5 * N + 3 * T)))
    sim = twin.probe_mm(q_rad, tool)
    chain = chain_of(arm)
    P = pose(chain, q_rad, delta, tool)
    J = jacobian(chain, P=P)
    grow = np.zeros(5 * N + 3 * T)
    grow[0 : 5 * N : 5], grow[1 : 5 * N : 5] = arm.a_mm, arm.d_mm
    grow[5 * N :] = arm.tool_offsets().ravel()
    at = chain.tool_frames[np.zeros(len(q_rad), int) if tool is None else tool]
    drivers: ArmDrivers = {
        "q": q_rad,
        "J": J,
        "Jq": in_readings(chain, J[:, :, [theta_index(j) for j in range(1, N + 1)]]),
        "grow": grow,
        "temp_c": temp_c,
        "t_s": t_s,
        "tau": in_readings(chain, twin.gravity_torques(q_rad)) if arm.has_masses else None,
        "point": P.point,
        "flange_R": P.link_R[np.arange(len(q_rad)), at],
        "delta_twin": np.asarray(twin.delta, float),
        "tool": tool,
        "flex": link_flex_columns(chain, P),
        "followers": chain.followers,
    }
    # the engine's functions take any dict of drivers; the TypedDict above checks this one's keys
    return cast("dict[str, Any]", drivers), sim


# The arm's practical floor: 3 % of the held-out RMS. Its null calibration (benchmarks/discover.py,
# the seed's arm and the UR10, 300 postures) gives no false claim at 2 %, and a real arm's
# recording holds several deterministic effects of a few per cent each (the UR10's gear harmonics).
ARM_FLOOR = 0.03


def discover_arm(
    rec, seed: int = 0, floor: float = ARM_FLOOR, arm=DEFAULT_ARM, truth=None
) -> tuple[dict, dict]:
    """discovery.json's content for an arm recording (in any instrument frame), and the figure's.

    The scene model: MuJoCo's nominal arm replays the encoder readings; the base-to-instrument
    frame and the tool point are registered with the data (always, as a user would); what is
    left is searched: the chain's geometry, each joint's compliance under the twin's gravity
    torques, encoder eccentricity, transmission harmonics, thermal growth, then a table over a
    joint's angle for what none of them explains.
    """
    from threadpoolctl import threadpool_limits

    from calibench.scenarios.progress import staged

    # thousands of small least-squares solves: one BLAS thread each is faster than several;
    # fit --effects discover's minutes, said apart from its calibration's
    with threadpool_limits(1), staged("discovering the effects"):
        return _discover_arm(rec, seed, floor, arm, truth)


def _discover_arm(rec, seed: int, floor: float, arm, truth=None) -> tuple[dict, dict]:
    """:func:`discover_arm`'s steps: the usable rows, fit's geometry, the residual signal, the
    candidates, the selection (then a phase per session only where it earns it, a joint's table
    for what is left), what carries to new sessions, and the words."""
    from calibench.estimators.arm.calibration import PRIOR
    from calibench.scenarios.arm_cmm.arms import chain_of, load_arm
    from calibench.scenarios.arm_cmm.training import calibrate

    arm = load_arm(arm) if isinstance(arm, (str, Path)) else arm
    N = arm.n_joints
    recs = list(rec) if isinstance(rec, (list, tuple)) else [rec]
    rows = usable_rows(recs, arm)
    T = arm.n_tools
    if truth is not None and truth.delta and len(truth.delta) != 5 * N + 3 * T:
        raise BadInput(
            f"the twin's truth.delta has {len(truth.delta)} values; the arm {arm.name} needs 5 x "
            f"{N} + 3{f' x {T}' if T > 1 else ''}"
        )
    chain = chain_of(arm)
    # fit's own step (fit --model physics where the arm has masses): the same prior, identifiable
    # basis and solve; its geometry is where the candidates' columns are taken, and its scatter
    # sets the weight of the prior's rows (a model without the compliance would scatter more, and
    # let the prior hold the geometry harder than fit does)
    model = "physics" if chain.has_masses else "geometry"
    solved = calibrate(
        chain,
        rows.q_rad,
        rows.xyz_mm,
        rows.rec_id,
        None,
        model,
        arm.parallel_pairs(),
        robust=False,
        prior=PRIOR,
        tool=rows.tool,
    )
    drivers, sim = arm_drivers(
        arm, rows.q_rad, rows.temp_c, rows.t_s, truth, solved.state.delta, rows.tool
    )
    drivers["rec"] = rows.rec_id
    # each joint's direction of last motion, over each recording's rows in their order
    drivers["dir_q"] = np.stack(
        [last_direction(rows.q_rad[:, j], rows.rec_id) for j in range(N)], axis=1
    )
    if chain.coupling is not None:  # and each motor's, its angle the inverse coupling's
        coupling = np.asarray(chain.coupling, float)
        drivers["dir_motor"] = directions(rows.q_rad, rows.rec_id, coupling)[:, N:]
    sig = residual_signal(chain, rows, solved.state, drivers, sim)
    among = arm_candidates(chain, arm, rows.q_rad, rows.xyz_mm, solved, drivers)
    # five contiguous blocks of each recording: every fold holds out a fifth of each setup
    fold = np.concatenate([np.minimum(np.arange(len(k)) * 5 // len(k), 4) for k in rows.parts])
    noise = {"xyz": Noise(None, 0.0, 0)}
    found, terms = select([sig], among.candidates, drivers, fold, noise, floor=floor)
    prune(sig, found, terms, drivers, fold, floor)
    shared_unless_sessions_differ(sig, found, terms["xyz"], drivers, fold, floor)
    add_joint_table(sig, found, terms, drivers, fold, rows.q_rad, floor)
    carry: dict[int, dict] = {}
    if len(recs) > 1:
        carry = carried_to_sessions(
            sig, found, terms["xyz"], drivers, fold, rows.rec_id, among.geometry
        )
    effects, fitted = describe_effects([sig], terms, found, drivers, noise)
    say_belonging(effects, found.steps, carry)
    # a joint's mechanism is named only when it beats its look-alikes held out
    duels = ties([sig], terms, among.candidates, drivers, fold)
    tied = named_only(effects, found, duels)
    said = {k for d in duels for k in (d.term.key, d.rival.key)}
    confounds = arm_confounds(sig, terms["xyz"], among.candidates, drivers, found, said) + tied
    accepted = {t.key for t in terms["xyz"]}
    confounds += [c for key, c in among.alike.items() if key in accepted]
    located = locate_arm(sig, terms["xyz"], drivers, seed)
    several = len(recs) > 1
    findings = Findings(
        scenario=NAME,
        samples=len(rows.q_rad),
        rms_nominal=float(np.sqrt(np.mean(sig.r**2))),
        found=found,
        effects=effects,
        located=located,
        confounded=confounds,
        judgement=judged(
            found.cv_final,
            {"xyz": arm_floor(fitted["xyz"], rows)},
            any(e["name"] != "geometry" for e in effects),
            located,
            lambda: locate_arm(
                dataclasses.replace(sig, r=fitted["xyz"]), terms["xyz"], drivers, seed
            ),
        ),
        holdout="five contiguous blocks of postures" + (" of each recording" if several else ""),
        scene_model=f"MuJoCo's nominal {arm.name} (drawing values, rigid), the base frame"
        + ("s" if several else "")
        + " and tool registered",
        not_accepted={**found.rejected, **among.not_applicable},
    )
    dropped = solved.ident.basis.dropped
    own = {
        "arm": arm.name,
        "dropped": [
            {"name": k, "why": v} for k, v in dropped.items() if not k.startswith(("base_", "tool"))
        ],
        "left_out_rows": rows.left_out,
        "summary": _arm_summary(arm.name, found, effects),
    }
    out = discovery_json(findings, own)
    return out, {
        "signals": [sig],
        "fitted": fitted,
        "rows_used": rows.parts,
        **structure(terms, drivers, fold),
    }


def _where(params: dict) -> str:
    """What an effect acts on, in words: a motor's cable or a joint."""
    if "link" in params:  # a branched arm's link that bends across
        return f"link {params['link']}"
    return f"motor {params['motor']}" if "motor" in params else f"joint {params.get('joint', '-')}"


def _arm_summary(name: str, found, effects: list) -> str:
    """discovery.json's summary: what the nominal arm leaves out, and the held-out RMS each
    effect found cut."""
    names = [e["name"] for e in effects if e["name"] != "geometry"]
    if not names:
        return (
            f"the nominal {name} with its geometry calibrated explains the recording to "
            f"{found.cv_final * 1000:.0f} um (held out): no other effect named"
        )
    steps = "; ".join(
        f"{e['name']} ({_where(e['params'])}): {e['cv_rms_before'] * 1000:.0f} -> "
        f"{e['cv_rms_after'] * 1000:.0f} um"
        for e in effects
        if e["name"] != "geometry"
    )
    return (
        f"the nominal {name} leaves out {', '.join(dict.fromkeys(names))}; held-out RMS "
        f"{found.cv_nominal * 1000:.0f} um with the drawing, {found.cv_final * 1000:.0f} um with "
        f"what was found ({steps})"
    )


def arm_truth(description, path: Path | None):
    """The arm twin's truth from a ``--config`` file's ``[arm-cmm.truth]`` (None: the nominal,
    rigid arm)."""
    if path is None:
        return None
    from calibench.scenarios.config import load_toml, override
    from calibench.sim.arm_cmm import ArmTruth

    t = override(
        ArmTruth(delta=(0.0,) * (5 * description.n_joints + 3 * description.n_tools)),
        load_toml(path).get(NAME, {}).get("truth", {}),
        "arm-cmm.truth",
    )
    return t


def twin_tables(scenario: str, out: dict, config: Path | None, arm=None) -> tuple[dict, list[str]]:
    """The arm's twin: the chain's errors (``delta``, the identifiable ones found, the dropped
    ones zero), each joint's stiffness from its compliance under gravity and each motor's cable
    stiffness from its cable's."""
    import math

    from calibench.estimators.arm.kinematics import param_names
    from calibench.scenes.arm_cmm import load_arm

    description = load_arm(arm or DEFAULT_ARM)
    N, T = description.n_joints, description.n_tools
    base = arm_truth(description, config)
    delta = list(base.delta) if base is not None and base.delta else [0.0] * (5 * N + 3 * T)
    stiffness = (
        list(base.stiffness_nm_per_rad)
        if base is not None and base.stiffness_nm_per_rad
        else [math.inf] * N
    )
    cables = (
        list(base.cable_stiffness_nm_per_rad)
        if base is not None and base.cable_stiffness_nm_per_rad
        else list(description.cable_stiffness_nm_per_rad or [math.inf] * N)
    )
    names, left = param_names(N, T), []
    flex = (
        list(base.flex_stiffness_nm_per_rad)
        if base is not None and base.flex_stiffness_nm_per_rad
        else [math.inf] * N
    )
    for e in out["effects"]:
        p = e["params"]
        if e["name"] == "geometry":
            for k, v in p.items():
                if k in names:
                    delta[names.index(k)] += v
        elif e["name"] == "joint_compliance" and p["urad_per_nm"] > 0:
            j = p["joint"] - 1
            c = p["urad_per_nm"] * 1e-6 + (1 / stiffness[j] if math.isfinite(stiffness[j]) else 0.0)
            stiffness[j] = 1 / c
        elif e["name"] == "link_flex" and p["urad_per_nm"] > 0:
            j = p["link"] - 1
            c = p["urad_per_nm"] * 1e-6 + (1 / flex[j] if math.isfinite(flex[j]) else 0.0)
            flex[j] = 1 / c
        elif e["name"] == "cable_compliance" and p["urad_per_nm"] > 0:
            m = p["motor"] - 1
            c = p["urad_per_nm"] * 1e-6 + (1 / cables[m] if math.isfinite(cables[m]) else 0.0)
            cables[m] = 1 / c
        else:
            left.append(e["name"] + (f" (joint {p['joint']})" if "joint" in p else ""))
    truth = {"delta": delta, "stiffness_nm_per_rad": stiffness}
    if any(math.isfinite(k) for k in flex):
        truth["flex_stiffness_nm_per_rad"] = flex
    if description.coupling is not None or any(math.isfinite(k) for k in cables):
        truth["cable_stiffness_nm_per_rad"] = cables
    from calibench.scenarios.discover.twin_merge import carried, given_tables

    return {NAME: carried(given_tables(config, NAME), {"truth": truth})}, left


# --- the plug-in (calibench.scenarios.discover.engine.Plugin) -------------------------------------
HOLDOUTS: tuple[str, ...] = ()  # its own folds: contiguous blocks of postures of each recording
MANY_RECORDINGS = True  # several sessions, each in its own instrument frame


@dataclasses.dataclass(frozen=True)
class ArmInput:
    """What ``discover arm-cmm`` reads: the arm's description, its recordings and their paths."""

    arm: object
    recordings: list
    paths: list


def load(scenario: str, paths: list, arm=None) -> ArmInput:
    """The arm (``arm``: an ARM.toml or a built-in arm's name; default the seed's arm-cmm) and
    its recordings at ``paths`` (docs/formats.md: q1_deg .. qN_deg, x_mm, y_mm, z_mm)."""
    from calibench.recordings import load_arm_csv
    from calibench.scenarios.discover.engine import MAX_ROWS
    from calibench.scenes.arm_cmm import load_arm

    if arm is not None and not str(arm).strip():
        raise BadInput("--arm is empty: give an ARM.toml or a built-in arm's name (arm-cmm, ur10)")
    description = load_arm(arm or DEFAULT_ARM)
    recs = [
        load_arm_csv(
            p,
            description.n_joints,
            MAX_ROWS,
            np.degrees(description.range_rad),
            description.follows,
            description.n_tools,
        )
        for p in paths
    ]
    return ArmInput(description, recs, list(paths))


def discover(scenario: str, rec: ArmInput, seed: int, holdout, config, arm=None):
    """:func:`discover_arm` on every recording (each its own frame), the twin of the
    ``run --config`` file ``config`` replaying them."""
    recs = rec.recordings
    out, fig = discover_arm(
        recs if len(recs) > 1 else recs[0],
        seed,
        arm=rec.arm,
        truth=arm_truth(rec.arm, config),
    )
    if len(rec.paths) > 1:
        out["recordings"] = [str(p) for p in rec.paths]
    return out, fig


def concealed(scenario: str, kind: str, seed: int, arm=None, **options) -> tuple[object, dict]:
    """The suites' proof set: a recording of the nominal ``arm`` (None: the seed's) with
    ``kind`` concealed (``sim.concealed.arm_recording``), and its sealed manifest; ``options``:
    the generator's (``noise``, ``repeat``)."""
    from calibench.sim.concealed import arm_recording

    return arm_recording(kind, seed, arm=arm or DEFAULT_ARM, **options)


def search(
    scenario: str, rec, seed: int, floor: float | None = None, arm=None
) -> tuple[dict, dict]:
    """discover's search on ``rec`` with the nominal ``arm`` (None: the seed's; ``floor``: None,
    the arm's)."""
    return discover_arm(rec, seed, ARM_FLOOR if floor is None else floor, arm=arm or DEFAULT_ARM)


def recording_kinds(scenario: str) -> tuple[str, ...]:
    """The effects a run's recording may conceal: the proof set's, then the second suite's and
    the third's."""
    from calibench.sim.concealed.arm import ARM_KINDS
    from calibench.sim.concealed.simulated import SIMULATED_ARM_KINDS
    from calibench.sim.concealed.unwritten import UNWRITTEN_ARM_KINDS

    return ARM_KINDS + UNWRITTEN_ARM_KINDS + SIMULATED_ARM_KINDS


def run_recording(scenario: str, config, seed: int) -> tuple[object, dict]:
    """``run``'s recording: the proof set's postures on the config's arm and truth,
    ``config.recording``'s effect concealed."""
    from calibench.sim.concealed.arm import arm_recording

    plan = config.recording
    return arm_recording(
        plan.conceal,
        seed,
        n=plan.postures,
        noise_um=plan.reference_noise_um,
        arm=config.arm,
        truth=config.truth,
    )
