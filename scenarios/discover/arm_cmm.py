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

import numpy as np

from calibench.estimators.discovery.arm import ArmDrivers
from calibench.estimators.discovery.fit import (
    Signal,
    cv_residuals,
    rms,
)
from calibench.estimators.discovery.noise import Noise
from calibench.estimators.discovery.select import Step, carry_to_new_sessions, prune, select
from calibench.scenarios.discover.arm_cmm_compliance import compliance_candidates
from calibench.scenarios.discover.arm_cmm_words import arm_confounds, locate_arm
from calibench.scenarios.discover.fresh import structure
from calibench.scenarios.discover.report import describe_effects
from calibench.scenarios.discover.same_machine import (
    SAME_ARM_MM,
    own_geometry_rms,
    refuse_another,
)
from calibench.scenarios.report import BadInput


def arm_drivers(
    arm, q_rad: np.ndarray, temp_c=None, t_s=None, truth=None, delta: np.ndarray | None = None
) -> tuple[dict, np.ndarray]:
    """What the arm's candidates need, and the twin's tool points: MuJoCo's nominal (rigid) arm
    at the readings (n, 3) mm, its gravity torques (MuJoCo's inverse dynamics) when the arm has
    masses, the chain's Jacobians, the twin's chain errors. ``truth``: a twin updated by
    ``discover --twin`` (its geometry, and its joints' stiffness: the links then settle under
    gravity in MuJoCo).
    ``delta``: the chain's errors (5 N + 3,) at which the Jacobians, the points and the flange
    are taken (the drawing's chain if None)."""
    from calibench.estimators.arm.kinematics import jacobian, pose, theta_index
    from calibench.scenarios.arm_cmm.arms import chain_of
    from calibench.sim.arm_cmm import ArmSim, ArmTruth

    N = arm.n_joints
    twin = ArmSim(arm, truth if truth is not None else ArmTruth(delta=(0.0,) * (5 * N + 3)))
    sim = twin.probe_mm(q_rad)
    chain = chain_of(arm)
    P = pose(chain, q_rad, delta)
    J = jacobian(chain, P=P)
    grow = np.zeros(5 * N + 3)
    grow[0 : 5 * N : 5], grow[1 : 5 * N : 5], grow[5 * N :] = arm.a_mm, arm.d_mm, arm.tool_mm
    drivers: ArmDrivers = {
        "q": q_rad,
        "J": J,
        "Jq": J[:, :, [theta_index(j) for j in range(1, N + 1)]],
        "grow": grow,
        "temp_c": temp_c,
        "t_s": t_s,
        "tau": twin.gravity_torques(q_rad) if arm.has_masses else None,
        "point": P.point,
        "flange_R": P.link_R[:, N],
        "delta_twin": np.asarray(twin.delta, float),
    }
    return drivers, sim


# The arm's practical floor: 3 % of the held-out RMS. Its null calibration (benchmarks/discover.py,
# the seed's arm and the UR10, 300 postures) gives no false claim at 2 %, and a real arm's
# recording holds several deterministic effects of a few per cent each (the UR10's gear harmonics).
ARM_FLOOR = 0.03


def discover_arm(
    rec, seed: int = 0, floor: float = ARM_FLOOR, arm="arm-cmm", truth=None
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
    from calibench.estimators.arm.calibration import PRIOR
    from calibench.estimators.arm.kinematics import parameter_scales, pose
    from calibench.estimators.arm.screening import screen
    from calibench.estimators.discovery.arm import (
        ArmDrift,
        ArmThermalExpansion,
        EncoderEccentricity,
        Geometry,
        TransmissionSearch,
        joint_table,
    )
    from calibench.estimators.discovery.harmonics import harmonic_grid
    from calibench.estimators.rotations import skew
    from calibench.scenarios.arm_cmm.arms import chain_of, load_arm
    from calibench.scenarios.arm_cmm.fit import calibrate, check_postures

    arm = load_arm(arm) if isinstance(arm, (str, Path)) else arm
    N = arm.n_joints
    recs = list(rec) if isinstance(rec, (list, tuple)) else [rec]
    parts, left_out = [], []
    for k, r in enumerate(recs):
        if r.n_joints != N:
            raise BadInput(f"recording {k + 1} has {r.n_joints} joints, the arm {arm.name} {N}")
    check_postures(np.vstack([r.q_rad for r in recs]), len(recs))
    for k, r in enumerate(recs):
        flagged = screen(r.q_rad, r.xyz_mm)
        # without a calibrated model neither row of a disagreeing repeat can be trusted: both go
        drop = sorted({int(i) for i in flagged.stale} | {int(i) for i in flagged.pairs.ravel()})
        parts.append(np.setdiff1d(np.arange(len(r.q_rad)), drop))
        tag = {} if len(recs) == 1 else {"recording": k + 1}
        left_out += [
            {**tag, "row": int(i), "why": "stale reading (repeats the previous row's point)"}
            for i in flagged.stale
        ]
        left_out += [
            {
                **tag,
                "row": int(i),
                "why": f"a repeat of row {int(o)} at the same angles disagrees by {d:.3f} mm",
            }
            for (a, b), d in zip(flagged.pairs, flagged.distance_mm)
            for i, o in ((a, b), (b, a))
        ]
    q = np.vstack([r.q_rad[k] for r, k in zip(recs, parts)])
    xyz = np.vstack([r.xyz_mm[k] for r, k in zip(recs, parts)])
    rec_id = np.concatenate([np.full(len(k), i) for i, k in enumerate(parts)])
    n = len(q)
    n_kin = 4 * N + len(arm.parallel_pairs())
    if min(len(k) for k in parts) < 12 or n < max(40, 2 * n_kin):
        raise BadInput(
            f"{n} usable postures ({', '.join(str(len(k)) for k in parts)} per recording): "
            f"discover needs at least {max(40, 2 * n_kin)} for the {arm.name}'s parameters"
        )

    def joined(name):
        cols = [getattr(r, name) for r in recs]
        return (
            None
            if any(c is None for c in cols)
            else np.concatenate([c[k] for c, k in zip(cols, parts)])
        )

    temp, t_s = joined("temp_c"), joined("t_s")
    if truth is not None and truth.delta and len(truth.delta) != 5 * N + 3:
        raise BadInput(
            f"the twin's truth.delta has {len(truth.delta)} values; the arm {arm.name} needs 5 x "
            f"{N} + 3"
        )
    chain = chain_of(arm)
    # fit's own step (fit --model physics where the arm has masses): the same prior, identifiable
    # basis and solve; its geometry is where the candidates' columns are taken, and its scatter
    # sets the weight of the prior's rows (a model without the compliance would scatter more, and
    # let the prior hold the geometry harder than fit does)
    model = "physics" if chain.has_masses else "geometry"
    solved = calibrate(
        chain, q, xyz, rec_id, None, model, arm.parallel_pairs(), robust=False, prior=PRIOR
    )
    problem, basis, s = solved.problem, solved.ident.basis, solved.state
    drivers, sim = arm_drivers(arm, q, temp, t_s, truth, delta=s.delta)
    # each recording's points in the arm's base frame, by the frame the geometry's fit found
    meas_base = np.einsum("nji,nj->ni", s.R[rec_id], xyz - s.t[rec_id])
    # The candidates are linear, the chain is not: over a 2 m arm a milliradian's error moves the
    # point's lever arms, and a tool guessed 100 mm off moves every joint's. So every column is
    # taken at the geometry's solution, and the signal loses the chain's remainder there
    # (f(d*) - f(d_twin) - J(d*) (d* - d_twin)): the geometry term then holds exactly at d*.
    at_twin = pose(chain, q, drivers["delta_twin"]).point
    remainder = (
        drivers["point"]
        - at_twin
        - np.einsum("nij,j->ni", drivers["J"], s.delta - drivers["delta_twin"])
    )
    r = meas_base - sim - remainder
    # the scene model's free columns: each frame (small turn and shift) and the shared tool point
    frame = np.zeros((n, 3, 6 * len(recs) + 3))
    for i in range(len(recs)):
        m = rec_id == i
        frame[m, :, 6 * i : 6 * i + 3] = -skew(drivers["point"][m])
        frame[m, :, 6 * i + 3 : 6 * i + 6] = np.eye(3)
    frame[:, :, -3:] = drivers["flange_R"]
    sig = Signal(
        "xyz_meas - xyz_sim", "xyz", r.ravel(), frame.reshape(3 * n, -1), np.repeat(np.arange(n), 3)
    )
    nk = 5 * N
    kin = tuple(int(k) for k in basis.kept if k < nk)
    names = tuple(problem.names[k] for k in kin)
    # the prior's rows weigh as fit's do: the fit's scatter per value over each error's prior std
    noise_mm = float(np.sqrt(np.mean((xyz - problem.model(s)) ** 2)))
    weight = noise_mm / (PRIOR * parameter_scales(names)) if PRIOR else ()
    geometry = Geometry(kept=kin, names=names, prior_weight=tuple(weight))
    # postures that move one joint only leave no kinematic error the frames and tool do not absorb
    candidates = [geometry] if kin else []
    candidates += [EncoderEccentricity(joint=j) for j in range(1, N + 1)]
    candidates += [
        TransmissionSearch(joint=j, harmonics=harmonic_grid(q[:, j - 1])) for j in range(1, N + 1)
    ]
    # several recordings: a joint's harmonic may also keep its frequency and take a phase per
    # recording (a motor-side error, its phase set at each power-up)
    drivers["rec"] = rec_id
    candidates += [
        TransmissionSearch(joint=j, harmonics=harmonic_grid(q[:, j - 1]), per_recording=True)
        for j in range(1, N + 1)
    ]
    compliance, not_applicable, alike = compliance_candidates(chain, q, drivers, arm.name)
    candidates += compliance
    candidates += [ArmThermalExpansion(), ArmDrift(driver="temp_c"), ArmDrift(driver="t_s")]
    candidates = [c for c in candidates if not hasattr(c, "applies") or c.applies(drivers)]
    # five contiguous blocks of each recording: every fold holds out a fifth of each setup
    fold = np.concatenate([np.minimum(np.arange(len(k)) * 5 // len(k), 4) for k in parts])
    noise = {"xyz": Noise(None, 0.0, 0)}
    found, terms = select([sig], candidates, drivers, fold, noise, floor=floor)
    prune(sig, found, terms, drivers, fold, floor)
    _shared_unless_sessions_differ(sig, found, terms["xyz"], drivers, fold, floor)
    # what no candidate explains: a table over one joint's angle, kept if it helps held out
    cache = {}
    cv_now = rms(cv_residuals(sig, terms["xyz"], drivers, fold, cache))
    best = None
    for j in range(1, N + 1):
        table = joint_table(q[:, j - 1], j)
        if table is None:
            continue
        cv = rms(cv_residuals(sig, terms["xyz"] + [table], drivers, fold, cache))
        if cv < (1 - floor) * cv_now and (best is None or cv < best[1]):
            best = (table, cv)
    if best is not None:
        terms["xyz"].append(best[0])
        found.steps.append(Step(best[0], "xyz", found.cv_final, best[1], 1 - best[1] / cv_now))
        found.cv_final = best[1]
    carry = {}
    if len(recs) > 1 and geometry in candidates:
        moved, left = own_geometry_rms(sig, terms["xyz"], geometry, drivers, rec_id)
        refuse_another(moved, left, SAME_ARM_MM, "arm", "link errors")
    if len(recs) > 1:
        carry = carry_to_new_sessions(
            sig, found, terms["xyz"], drivers, fold, rec_id, _register_rows(rec_id)
        )
    effects, fitted = describe_effects([sig], terms, found, drivers, noise)
    for st, e in zip(found.steps, effects):
        if id(st.term) in carry:
            e["belongs"] = "session" if getattr(st.term, "per_recording", False) else "machine"
            e["new_session_rms"] = carry[id(st.term)]
            if getattr(st.term, "session_refit", False):
                what = "values" if st.term.name == "nonsmooth" else "amplitude and phase"
                e["new_session"] = f"its {what} refitted on the session's registration rows"
    confounds = arm_confounds(sig, terms["xyz"], candidates, drivers, found)
    accepted = {t.key for t in terms["xyz"]}
    confounds += [c for key, c in alike.items() if key in accepted]
    located = locate_arm(sig, terms["xyz"], drivers, q, temp, seed)
    names = [e["name"] for e in effects if e["name"] != "geometry"]
    out = {
        "scenario": "arm-cmm",
        "arm": arm.name,
        "samples": n,
        "unit": "mm",
        "located": located,
        "effects": effects,
        "fit": {
            "rms_nominal": float(np.sqrt(np.mean(sig.r**2))),
            "cv_rms_nominal": found.cv_nominal,
            "cv_rms_final": found.cv_final,
        },
        "holdout": "five contiguous blocks of postures"
        + (" of each recording" if len(recs) > 1 else ""),
        "scene_model": f"MuJoCo's nominal {arm.name} (drawing values, rigid), the base frame"
        + ("s" if len(recs) > 1 else "")
        + " and tool registered",
        "dropped": [
            {"name": k, "why": v}
            for k, v in basis.dropped.items()
            if not k.startswith(("base_", "tool_"))
        ],
        "left_out_rows": left_out,
        "not_accepted": {**found.rejected, **not_applicable},
        "confounded": confounds,
        "summary": _arm_summary(arm.name, found, effects, names),
    }
    return out, {
        "signals": [sig],
        "fitted": fitted,
        "rows_used": parts,
        **structure(terms, drivers, fold),
    }


REGISTER_FRACTION = 0.2  # of a session held out whole: the rows its own terms are fitted on


def _register_rows(rec_id: np.ndarray) -> np.ndarray:
    """(n,) bool: a fixed draw of :data:`REGISTER_FRACTION` of each session's rows (fit's
    --leave-one-out registers a new session on as many)."""
    out = np.zeros(len(rec_id), bool)
    rng = np.random.default_rng(0)
    for k in np.unique(rec_id):
        rows = rng.permutation(np.flatnonzero(rec_id == k))
        out[rows[: max(int(round(REGISTER_FRACTION * len(rows))), 3)]] = True
    return out


def _shared_unless_sessions_differ(sig, found, terms: list, drivers, fold, floor: float) -> None:
    """A harmonic with a phase per recording stays so only if it beats the same harmonic with
    one phase for all by ``floor`` of the held-out RMS (the extra coefficients otherwise fit
    noise): replaced in ``terms`` and in its step otherwise."""
    for i, t in enumerate(terms):
        if not getattr(t, "per_recording", False):
            continue
        shared = dataclasses.replace(t, per_recording=False)
        cv_per = rms(cv_residuals(sig, terms, drivers, fold, {}))
        cv_shared = rms(cv_residuals(sig, terms[:i] + [shared] + terms[i + 1 :], drivers, fold, {}))
        if cv_per > (1 - floor) * cv_shared:
            for k, st in enumerate(found.steps):
                if (
                    st.term is t
                ):  # the last step's figure is the final one: both now the shared term's
                    last = k == len(found.steps) - 1
                    found.steps[k] = dataclasses.replace(
                        st, term=shared, cv_after=cv_shared if last else st.cv_after
                    )
            terms[i] = shared
            found.cv_final = cv_shared


def _where(params: dict) -> str:
    """What an effect acts on, in words: a motor's cable or a joint."""
    return f"motor {params['motor']}" if "motor" in params else f"joint {params.get('joint', '-')}"


def _arm_summary(name: str, found, effects: list, names: list) -> str:
    if not names:
        return (
            f"the nominal {name} with its geometry calibrated explains the recording to "
            f"{found.cv_final * 1000:.0f} um (held out): nothing else found"
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
        ArmTruth(delta=(0.0,) * (5 * description.n_joints + 3)),
        load_toml(path).get("arm-cmm", {}).get("truth", {}),
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

    description = load_arm(arm or "arm-cmm")
    N = description.n_joints
    base = arm_truth(description, config)
    delta = list(base.delta) if base is not None and base.delta else [0.0] * (5 * N + 3)
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
    names, left = param_names(N), []
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
        elif e["name"] == "cable_compliance" and p["urad_per_nm"] > 0:
            m = p["motor"] - 1
            c = p["urad_per_nm"] * 1e-6 + (1 / cables[m] if math.isfinite(cables[m]) else 0.0)
            cables[m] = 1 / c
        else:
            left.append(e["name"] + (f" (joint {p['joint']})" if "joint" in p else ""))
    truth = {"delta": delta, "stiffness_nm_per_rad": stiffness}
    if description.coupling is not None or any(math.isfinite(k) for k in cables):
        truth["cable_stiffness_nm_per_rad"] = cables
    from calibench.scenarios.discover.twin_merge import carried, given_tables

    return {"arm-cmm": carried(given_tables(config, "arm-cmm"), {"truth": truth})}, left


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
    description = load_arm(arm or "arm-cmm")
    recs = [
        load_arm_csv(p, description.n_joints, MAX_ROWS, np.degrees(description.range_rad))
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
