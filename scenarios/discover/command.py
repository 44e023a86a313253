"""``calibench discover``: where a recording disagrees with the twin, and which physics is missing.

Stages (belt-stage, vision-stage): the twin replays the commands (``sim.replay``); the scene's
own error model (the belt stage's quadratic map, the vision stage's cubic one) is calibrated
with the data, as any user would; what is left is searched for missing effects. The arm: the
nominal chain replays the encoder readings; the chain's geometry is itself a candidate.

Writes DIR/discovery.json (CONTRACT) and DIR/discovery.png (residual maps before and after).
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np

from calibench.estimators.discovery.fit import (
    Signal,
    confounded,
    cv_residuals,
    fit_terms,
    lstsq,
    rms,
)
from calibench.estimators.discovery.locate import change_point, permutation_p, reversal_profile
from calibench.estimators.discovery.noise import Noise, repeatability
from calibench.estimators.discovery.nonsmooth import find_nonsmooth
from calibench.estimators.discovery.select import FLOOR, Step, prune, refine, select
from calibench.estimators.discovery.stage import (
    PeriodSearch,
    polynomial_candidates,
    stage_candidates,
)
from calibench.recordings import same_file
from calibench.scenarios.report import BadInput

STAGE_DEGREE = {"belt-stage": 2, "vision-stage": 3}
SUPPORTED = ("belt-stage", "vision-stage", "arm-cmm", "probe-scanner", "stewart")
STAGES = ("belt-stage", "vision-stage")  # the scenarios whose folds --holdout chooses
# Rows per recording: the candidates' design matrices grow with it (a 1e6-row stage recording
# would need tens of GB); refused before any work, with the advice to decimate.
MAX_ROWS = 100_000
EXPERIMENTS = {
    "thermal_expansion": "let the machine's temperature change by several K during the test (or repeat it warm "
    "and cold): only then does thermal expansion differ from a plain scale error",
    "thermal_drift": "hold the temperature steady for part of the test, or vary it independently of time",
    "backlash": "approach every station from both directions",
    "periodic": "measure at a finer step over a longer travel",
    "positioning": "measure more stations along the axis",
    "straightness": "measure more lines across the travel",
    "cross_coupling": "measure a full grid rather than lines",
}


def poly_base(x: np.ndarray, y: np.ndarray, degree: int, span: tuple[float, float]) -> np.ndarray:
    """The scene's error model as columns: monomials x^i y^j, i + j <= degree (scaled)."""
    u, v = x / max(span[0], 1e-9), y / max(span[1], 1e-9)
    return np.stack([u**i * v ** (k - i) for k in range(degree + 1) for i in range(k + 1)], axis=1)


def folds_for(rec_run, x, y, holdout: str | None) -> tuple[np.ndarray, str]:
    """Fold label per sample: whole passes when there are several, else whole rows (or columns)
    of a grid, else five contiguous blocks in time. A scheme asked for by name that the
    recording cannot give (one pass, no grid) is bad input, not quietly another scheme."""
    passes = rec_run is not None and len(np.unique(rec_run)) >= 2
    rows, cols = len(np.unique(y)) <= len(y) / 4, len(np.unique(x)) <= len(x) / 4
    if holdout == "pass" and not passes:
        raise BadInput(
            "--holdout pass: the recording has one pass (its run column); hold out rows, columns or blocks"
        )
    if holdout == "rows" and not rows:
        raise BadInput(
            f"--holdout rows: the recording's y values are not rows of a grid ({len(np.unique(y))} "
            f"distinct in {len(y)} samples); hold out blocks"
        )
    if holdout == "columns" and not cols:
        raise BadInput(
            f"--holdout columns: the recording's x values are not columns of a grid "
            f"({len(np.unique(x))} distinct in {len(x)} samples); hold out blocks"
        )
    if holdout in (None, "pass") and passes:
        return np.unique(rec_run, return_inverse=True)[1], "leave one pass out"
    if holdout in (None, "rows") and rows:
        return np.unique(y, return_inverse=True)[1], "leave one row (y) out"
    if holdout == "columns":
        return np.unique(x, return_inverse=True)[1], "leave one column (x) out"
    return np.minimum(np.arange(len(x)) * 5 // len(x), 4), "five contiguous blocks"


# --- stages --------------------------------------------------------------------------------------
def discover_stage(
    scenario: str,
    rec,
    seed: int = 0,
    holdout: str | None = None,
    floor: float = FLOOR,
    truth=None,
) -> tuple[dict, dict]:
    """discovery.json's content for a stage recording, and what the figure needs. ``truth``:
    the twin's as-built parameters (a ``--config`` file's; default: the scenario's own)."""
    from calibench.sim.replay import replay_stage

    n = len(rec)
    x, y = rec.x_cmd_mm, rec.y_cmd_mm
    if n < 20:
        raise BadInput(f"{n} stations: discover needs at least 20")
    _within_travel(scenario, x, y)
    sim = replay_stage(scenario, x, y, rec.temp_c, truth)
    drivers = {
        "x": x,
        "y": y,
        "dir_x": rec.dir_x,
        "dir_y": rec.dir_y,
        "t_s": rec.t_s,
        "temp_c": rec.temp_c,
        "run": rec.run,
    }
    span = (max(np.ptp(x), 1.0), max(np.ptp(y), 1.0))
    deg = STAGE_DEGREE[scenario]
    base = poly_base(x, y, deg, span)
    if np.linalg.matrix_rank(base) < base.shape[1]:
        raise BadInput(
            f"the stations do not span the {scenario} error model (degree {deg} in x and y): "
            "measure a grid or lines along both axes"
        )
    idx = np.arange(n)
    signals = [
        Signal("x_meas - x_sim", "x", rec.x_meas_mm - sim[:, 0], base, idx, x),
        Signal("y_meas - y_sim", "y", rec.y_meas_mm - sim[:, 1], base, idx, y),
    ]
    fold, scheme = folds_for(rec.run, x, y, holdout)
    order = rec.t_s if rec.t_s is not None else idx.astype(float)
    dirs = [np.zeros(n) if d is None else d for d in (rec.dir_x, rec.dir_y)]
    key = np.unique(np.stack([x, y, *dirs], axis=1).round(6), axis=0, return_inverse=True)[
        1
    ].ravel()
    noise = {s.axis: repeatability(s.r - base @ lstsq(base, s.r), key, order) for s in signals}
    step = np.median(np.diff(np.unique(np.r_[x, y]))) if len(np.unique(np.r_[x, y])) > 1 else 1.0
    candidates = stage_candidates(drivers)
    for a, u in (("x", x), ("y", y)):
        lo, hi = max(2.5 * step, 5.0), np.ptp(u) / 2
        if hi > lo:  # uniform in frequency, five points per resolution element (1 / travel)
            f = np.arange(1 / hi, 1 / lo, 1 / (5 * np.ptp(u)))
            candidates.append(PeriodSearch(a, 1 / f))
        candidates += polynomial_candidates(a, deg)
    found, terms = select(signals, candidates, drivers, fold, noise, floor=floor)
    growing = _grow_backlash(signals, terms, found, drivers, fold, noise, floor)

    # nonsmooth: what stands out of the repeatability after the accepted effects
    pos_key, pos_inv = np.unique(np.stack([x, y], axis=1).round(6), axis=0, return_inverse=True)
    pos_inv = pos_inv.ravel()
    for s in signals:
        table = find_nonsmooth(
            s, terms[s.axis], drivers, pos_inv, pos_key, noise[s.axis], fold, floor
        )
        if table is not None:
            cv_sq = {
                t.axis: float(np.sum(cv_residuals(t, terms[t.axis], drivers, fold, {}) ** 2))
                for t in signals
            }
            before = np.sqrt(sum(cv_sq.values()) / (2 * n))
            cv_sq[s.axis] = float(
                np.sum(cv_residuals(s, terms[s.axis] + [table], drivers, fold, {}) ** 2)
            )
            after = np.sqrt(sum(cv_sq.values()) / (2 * n))
            terms[s.axis].append(table)
            found.steps.append(Step(table, s.axis, float(before), float(after), 0.0))
            found.cv_final = float(after)

    effects, fitted = _describe(signals, terms, found, drivers, noise)
    for e in effects:
        if e["name"] == "backlash" and e["axis"] in growing:
            e["grows_along_travel"] = True
            e["cv_rms_constant_reversal"], e["cv_rms_growing_reversal"] = growing[e["axis"]]
            e["physics"] += (
                f" (held out on {e['axis']}: {growing[e['axis']][0] * 1000:.2f} um with a constant "
                f"reversal, {growing[e['axis']][1] * 1000:.2f} um with one that grows)"
            )
    # the repeatability again, after the accepted effects: an effect that drifts between passes
    # (temperature, a creeping offset) inflates the first estimate
    after = {a: repeatability(fitted[a], key, order) for a in fitted}
    located = _locate_stage(signals, drivers, seed)
    confounds = _confounds(signals, terms, found, candidates, drivers, rec)
    out = {
        "scenario": scenario,
        "samples": n,
        "unit": "mm",
        "located": located,
        "effects": effects,
        "fit": {
            "rms_nominal": found.rms_nominal,
            "cv_rms_nominal": found.cv_nominal,
            "cv_rms_final": found.cv_final,
        },
        "noise": {
            a: {"repeatability_mm": nz.sigma_mm, "lag1_correlation": nz.lag1, "dof": nz.dof}
            for a, nz in noise.items()
        },
        "noise_after_effects": {
            a: {"repeatability_mm": nz.sigma_mm, "dof": nz.dof} for a, nz in after.items()
        },
        "holdout": scheme,
        "scene_model": f"the twin plus its degree-{deg} error map in (x, y), calibrated",
        "temp_mean_c": None if rec.temp_c is None else float(np.mean(rec.temp_c)),
        "not_accepted": found.rejected,
        "confounded": confounds,
        "verdict": verdict(found.cv_final, after, bool(effects)),
    }
    return out, {"signals": signals, "fitted": fitted, "x": x, "y": y}


def _grow_backlash(signals, terms, found, drivers, fold, noise, floor) -> dict:
    """Does an accepted lost motion grow along its axis's travel (an elastic drive)? Where it
    does, the term becomes the growing one in place. Returns axis -> (held-out RMS of that axis
    with a constant reversal, with the growing one)."""
    from calibench.estimators.discovery.stage import Backlash

    out = {}
    for s in signals:
        for i, t in enumerate(terms[s.axis]):
            if not (isinstance(t, Backlash) and t.span_mm is None):
                continue
            u = np.asarray(drivers[s.axis], float)
            richer = Backlash(axis=s.axis, span_mm=(float(u.min()), float(u.max())))
            ok, before, after = refine(
                s, terms[s.axis], i, richer, drivers, fold, noise[s.axis], floor
            )
            if ok:
                terms[s.axis][i] = richer
                for st in found.steps:
                    if st.term is t:
                        st.term = richer
                out[s.axis] = (before, after)
    if out:
        cv_sq = sum(
            float(np.sum(cv_residuals(s, terms[s.axis], drivers, fold, {}) ** 2)) for s in signals
        )
        found.cv_final = float(np.sqrt(cv_sq / sum(len(s.r) for s in signals)))
    return out


UNEXPLAINED_RATIO = 1.5  # held-out RMS over repeatability beyond which something is left


def _within_travel(scenario: str, x: np.ndarray, y: np.ndarray) -> None:
    """BadInput when a commanded station lies beyond the twin's travel (by more than 5 % of it):
    the twin cannot replay it, and a recording there is in another unit or of another stage."""
    from calibench.sim.replay import stage_travel_mm

    travel = stage_travel_mm(scenario)
    for axis, v, t in (("x", x, travel[0]), ("y", y, travel[1])):
        if v.min() < -0.05 * t or v.max() > 1.05 * t:
            raise BadInput(
                f"{axis}_cmd_mm reaches {v.min() if v.min() < -0.05 * t else v.max():.6g} mm; the twin's "
                f"{scenario} travels 0-{t:g} mm in {axis}: a wrong unit (um?) or another stage"
            )


def one_axis_fit(axis: str, rms_nominal: float, found, noise: dict, after_noise: dict) -> dict:
    """discovery.json's ``fit``, ``noise`` and ``noise_after_effects`` of a one-signal instrument
    (the probe scanner, the Stewart platform): ``found`` the selection, ``noise`` and
    ``after_noise`` the repeatability before and after the accepted effects, by axis."""
    return {
        "fit": {
            "rms_nominal": float(rms_nominal),
            "cv_rms_nominal": found.cv_nominal,
            "cv_rms_final": found.cv_final,
        },
        "noise": {
            axis: {
                "repeatability_mm": noise[axis].sigma_mm,
                "lag1_correlation": noise[axis].lag1,
                "dof": noise[axis].dof,
            }
        },
        "noise_after_effects": {
            axis: {"repeatability_mm": after_noise[axis].sigma_mm, "dof": after_noise[axis].dof}
        },
    }


def verdict(cv_final_mm: float, noise: dict, found_any: bool) -> str:
    """What is left after the accepted effects, in words: the final held-out RMS (per
    coordinate) against the repeatability from repeats (``noise``: axis -> Noise, after the
    effects). Never a silent stop: unexplained structure, or no repeats to judge by, is said."""
    sig = [nz.sigma_mm for nz in noise.values() if nz.sigma_mm]
    left = cv_final_mm * 1000
    if not sig:
        return (
            f"what is left: {left:.2f} um held out; no station was visited twice, so the repeatability is "
            "unknown and it cannot be said whether that is noise"
        )
    floor = float(np.sqrt(np.mean(np.square(sig)))) * 1000
    if cv_final_mm * 1000 > UNEXPLAINED_RATIO * floor:
        return (
            f"unexplained: {left:.2f} um held out against {floor:.2f} um of repeatability; the recording holds "
            "structure no candidate explains"
        )
    what = (
        "the accepted effects explain" if found_any else "nothing missing: the scene model explains"
    )
    return f"{what} the recording to its repeatability ({left:.2f} um held out, {floor:.2f} um from repeats)"


def _describe(signals, terms, found, drivers, noise):
    """Each accepted effect's parameters and standard errors from the final all-data fit."""
    by_axis = {s.axis: s for s in signals}
    fitted, described = {}, {}
    for a, sig in by_axis.items():
        nz = noise.get(a)
        sigma = nz.sigma_mm * nz.inflation if nz is not None and nz.sigma_mm else None
        fixed, coef, cov, res = fit_terms(sig, terms[a], drivers, {}, sigma)
        fitted[a] = res
        for term, (t, start, k) in zip(
            terms[a], fixed
        ):  # keyed by the term as selected (a search, fixed here)
            p, e, text = t.describe(
                coef[start : start + k], cov[start : start + k, start : start + k]
            )
            described[id(term)] = (t, p, e, text)
    effects = []
    for st in found.steps:
        t, p, e, text = described[id(st.term)]
        effects.append(
            {
                "name": t.name,
                "axis": st.axis,
                "params": _plain(p),
                "stderr": _plain(e),
                "physics": text,
                "cv_rms_before": st.cv_before,
                "cv_rms_after": st.cv_after,
            }
        )
    return effects, fitted


def _plain(d):
    def one(v):
        if isinstance(v, (str, bool, np.bool_)) or v is None:
            return v if not isinstance(v, np.bool_) else bool(v)
        if isinstance(v, (list, tuple, np.ndarray)):
            return [one(x) for x in v]
        return int(v) if isinstance(v, (int, np.integer)) else float(v)

    return {k: one(v) for k, v in d.items()}


def _locate_stage(signals, drivers, seed):
    """Each residual (after the scene model) against each driver, whole-pass permutation tests."""
    rng = np.random.default_rng(seed)
    passes = drivers["run"] if drivers.get("run") is not None else np.zeros(len(signals[0].r))
    out = []
    for s in signals:
        r = s.r - s.base @ lstsq(s.base, s.r)
        for name in ("x", "y", "dir_x", "dir_y", "t_s", "temp_c"):
            v = drivers.get(name)
            if v is None or np.ptp(v) == 0:
                continue
            score, p = permutation_p(
                r, np.asarray(v, float), passes, name in ("t_s", "temp_c"), rng
            )
            if p > 0.01 or score < 0.02:
                continue
            out.append(
                {
                    "signal": s.name,
                    "driver": name,
                    "score": score,
                    "p_value": p,
                    "where": _where(r, np.asarray(v, float), name, drivers),
                }
            )
    return sorted(out, key=lambda d: -d["score"])


def _where(r, v, name, drivers):
    if name.startswith("dir_"):
        axis = name[-1]
        c, prof = reversal_profile(r, np.asarray(drivers[axis], float), v)
        ok = np.isfinite(prof)
        return (
            f"whole {axis.upper()} travel: forward minus backward {np.nanmean(prof) * 1000:+.1f} um "
            f"(from {np.nanmin(prof[ok]) * 1000:+.1f} to {np.nanmax(prof[ok]) * 1000:+.1f} um along it)"
        )
    if name in ("t_s", "temp_c"):
        k, stat = change_point(
            r[np.argsort(drivers["t_s"])] if drivers.get("t_s") is not None else r
        )
        unit = "s" if name == "t_s" else "deg C"
        return f"follows {name} ({unit}); largest shift after sample {k} (CUSUM {stat:.1f})"
    edges = np.quantile(v, np.linspace(0, 1, 9))
    idx = np.clip(np.searchsorted(edges, v, side="right") - 1, 0, 7)
    means = np.array([np.mean(r[idx == k]) if np.any(idx == k) else 0 for k in range(8)])
    k = int(np.argmax(np.abs(means)))
    return (
        f"largest at {name} {edges[k]:.0f}-{edges[k + 1]:.0f} mm (mean {means[k] * 1000:+.1f} um)"
    )


def _confounds(signals, terms, found, candidates, drivers, rec):
    """Physical candidates the data cannot tell from what the model already has, each with the
    experiment that would (smooth polynomial terms are left out: they are meant to overlap)."""
    out = []
    by_axis = {s.axis: s for s in signals}
    accepted = {st.term.key for st in found.steps} | {
        f"{st.term.name}:{st.axis}" for st in found.steps
    }
    for c in candidates:
        if (
            c.key in accepted
            or isinstance(c, PeriodSearch)
            or c.name in ("positioning", "straightness", "cross_coupling")
        ):
            continue
        frac = confounded(by_axis[c.axis], terms[c.axis], c, drivers, {})
        if c.name == "thermal_expansion" and np.ptp(rec.temp_c) < 1.0:
            out.append(
                {
                    "effect": c.name,
                    "axis": c.axis,
                    "with": "scale",
                    "why": f"the temperature moved only {np.ptp(rec.temp_c):.2f} K, so an expansion "
                    f"coefficient would look like (and be absorbed by) a scale error",
                    "experiment": EXPERIMENTS[c.name],
                }
            )
        elif frac > 0.9:
            out.append(
                {
                    "effect": c.name,
                    "axis": c.axis,
                    "with": "the scene model and the accepted effects",
                    "why": f"{100 * frac:.0f} % of its effect on the data is also what the model already has",
                    "experiment": EXPERIMENTS.get(c.name, "vary its driver independently"),
                }
            )
    return out


# --- the arm ---------------------------------------------------------------------------------------
ARM_EXPERIMENTS = {
    "joint_compliance": "take postures where the other joints change this joint's gravity torque (the elbow "
    "folded and stretched at the same shoulder angle), or add a known payload",
    "encoder_eccentricity": "take postures at the same gravity torque over the joint's whole turn",
    "transmission": "measure over a wider range of the joint's angle at a finer step",
    "thermal_expansion": "let the arm's temperature change by several K during the recording",
}


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
    drivers = {
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

    # thousands of small least-squares solves: one BLAS thread each is faster than several
    with threadpool_limits(1):
        return _discover_arm(rec, seed, floor, arm, truth)


def _discover_arm(rec, seed: int, floor: float, arm, truth=None) -> tuple[dict, dict]:
    from calibench.estimators.arm.kinematics import pose
    from calibench.estimators.arm.screening import screen
    from calibench.estimators.discovery.arm import (
        ArmThermalExpansion,
        EncoderEccentricity,
        Geometry,
        JointCompliance,
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
            f"{n} usable postures ({', '.join(str(len(k)) for k in parts)} per recording): discover "
            f"needs at least {max(40, 2 * n_kin)} for the {arm.name}'s parameters"
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
            f"the twin's truth.delta has {len(truth.delta)} values; the arm {arm.name} needs 5 x {N} + 3"
        )
    chain = chain_of(arm)
    solved = calibrate(
        chain, q, xyz, rec_id, None, "geometry", arm.parallel_pairs(), robust=False, prior=None
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
    geometry = Geometry(kept=kin, names=tuple(problem.names[k] for k in kin))
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
    not_applicable = {}
    if drivers["tau"] is not None:
        candidates += [JointCompliance(joint=j) for j in range(1, N + 1)]
    else:
        not_applicable["joint_compliance"] = (
            f"the arm file {arm.name} gives no masses: no gravity torques"
        )
    thermal = ArmThermalExpansion()
    if thermal.applies(drivers):
        candidates.append(thermal)
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
    effects, fitted = _describe([sig], terms, found, drivers, noise)
    confounds = _arm_confounds(sig, terms["xyz"], candidates, drivers, found)
    located = _locate_arm(sig, terms["xyz"], drivers, q, temp, seed)
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
    return out, {"signals": [sig], "fitted": fitted}


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


def _arm_summary(name: str, found, effects: list, names: list) -> str:
    if not names:
        return (
            f"the nominal {name} with its geometry calibrated explains the recording to "
            f"{found.cv_final * 1000:.0f} um (held out): nothing else found"
        )
    steps = "; ".join(
        f"{e['name']} (joint {e['params'].get('joint', '-')}): {e['cv_rms_before'] * 1000:.0f} -> "
        f"{e['cv_rms_after'] * 1000:.0f} um"
        for e in effects
        if e["name"] != "geometry"
    )
    return (
        f"the nominal {name} leaves out {', '.join(dict.fromkeys(names))}; held-out RMS "
        f"{found.cv_nominal * 1000:.0f} um with the drawing, {found.cv_final * 1000:.0f} um with what was found "
        f"({steps})"
    )


def _arm_confounds(sig, terms, candidates, drivers, found) -> list[dict]:
    """Candidates the data cannot tell from what was accepted, in plain words: compliance and
    eccentricity of one joint look alike when its gravity torque is nearly a sinusoid of its own
    angle; a compliance the geometry absorbs within these postures (a narrow band of the joint)
    would still matter on postures that load the joint otherwise."""
    out = []
    accepted = {t.key for t in terms}
    for c in candidates:
        if c.key in accepted or c.name not in ("joint_compliance", "encoder_eccentricity"):
            continue
        other = (
            "encoder_eccentricity" if c.name == "joint_compliance" else "joint_compliance"
        ) + f":joint{c.joint}"
        frac = confounded(sig, terms, c, drivers, {})
        if frac <= 0.9:
            continue
        if other in accepted:
            out.append(
                {
                    "effect": c.name,
                    "axis": "xyz",
                    "with": other,
                    "why": f"joint {c.joint}'s gravity torque is nearly a sinusoid of its own angle in these "
                    f"postures: {100 * frac:.0f} % of {c.name}'s effect is what {other} already explains",
                    "experiment": ARM_EXPERIMENTS[c.name],
                }
            )
        elif c.name == "joint_compliance" and np.ptp(drivers["tau"][:, c.joint - 1]) > 0:
            tau = drivers["tau"][:, c.joint - 1]
            out.append(
                {
                    "effect": c.name,
                    "axis": "xyz",
                    "with": "geometry",
                    "why": f"within these postures joint {c.joint}'s gravity torque ({tau.min():.0f} to "
                    f"{tau.max():.0f} N m) moves the point almost as the kinematic errors do: "
                    f"{100 * frac:.0f} % of a compliance's effect is absorbed by them, so the recording "
                    f"cannot show it, yet a calibration without it will not carry to postures that load "
                    f"the joint otherwise",
                    "experiment": ARM_EXPERIMENTS[c.name],
                }
            )
    return out


def _locate_arm(sig, terms, drivers, q, temp, seed) -> list[dict]:
    """The residual after the geometry against each joint angle and the temperature."""
    rng = np.random.default_rng(seed)
    n = len(q)
    geo = [t for t in terms if t.name == "geometry"]
    _, _, _, res = fit_terms(sig, geo, drivers, {}, None)
    res3 = res.reshape(n, 3)
    located = []
    for name, v in [(f"q{j}", q[:, j - 1]) for j in range(1, q.shape[1] + 1)] + [("temp_c", temp)]:
        if v is None or np.ptp(v) == 0:
            continue
        best = max(
            (
                permutation_p(res3[:, k], v, np.zeros(n), name == "temp_c", rng, 99) + (k,)
                for k in range(3)
            ),
            key=lambda t: t[0],
        )
        if best[1] <= 0.01 and best[0] >= 0.02:
            located.append(
                {
                    "signal": f"{'xyz'[best[2]]}_meas - {'xyz'[best[2]]}_sim (after geometry)",
                    "driver": name,
                    "score": best[0],
                    "p_value": best[1],
                    "where": f"over the whole range of {name}",
                }
            )
    located.sort(key=lambda d: -d["score"])
    return located


def paper_belt_recording(data_dir: Path):
    """The seed paper's measured belt-stage tables (../shared/data/seed_belt_stage) as a stage
    recording: one row per station, error = measured - commanded (no passes, no directions)."""
    from calibench.recordings import StageRecording

    ex = np.loadtxt(Path(data_dir) / "x_axis_error_mm.csv", delimiter=",", skiprows=1)
    ey = np.loadtxt(Path(data_dir) / "y_axis_error_mm.csv", delimiter=",", skiprows=1)
    if not np.array_equal(ex[:, :2], ey[:, :2]):
        raise BadInput("the X and Y tables list different stations")
    x, y = ex[:, 0], ex[:, 1]
    return StageRecording(x_cmd_mm=x, y_cmd_mm=y, x_meas_mm=x + ex[:, 2], y_meas_mm=y + ey[:, 2])


# --- the command -----------------------------------------------------------------------------------
TWIN_SCENARIOS = SUPPORTED  # discover --twin / --config so far


def run_discover(
    scenario: str,
    csv_path,
    out_dir: Path,
    seed: int = 0,
    holdout: str | None = None,
    arm: str | Path | None = None,
    config: Path | None = None,
    twin: Path | None = None,
) -> dict:
    """``csv_path``: a recording, or for arm-cmm several (each its own base frame). ``config``:
    a ``run --config`` file whose twin replays the recording; ``twin``: where to write the twin
    updated with what was found (same format)."""
    if (config or twin) and scenario not in TWIN_SCENARIOS:
        raise BadInput(
            f"discover --config/--twin: written for {', '.join(TWIN_SCENARIOS)} so far, not {scenario}"
        )
    paths = list(csv_path) if isinstance(csv_path, (list, tuple)) else [csv_path]
    if scenario != "arm-cmm" and len(paths) != 1:
        raise BadInput(f"discover {scenario}: one recording, not {len(paths)}")
    if config is not None:
        from calibench.scenarios.config import load_toml

        tables = load_toml(config)
        if scenario not in tables:
            raise BadInput(
                f"config {config} has no [{scenario}] table (it has: {', '.join(tables) or 'none'}): "
                "its twin is not this instrument's"
            )
    if twin is not None and any(same_file(twin, p) for p in paths):
        raise BadInput(f"--twin {twin} is a recording of this run: the twin would overwrite it")
    from calibench.recordings import load_arm_csv, load_stage_csv

    if scenario not in SUPPORTED:
        raise BadInput(f"discover supports {', '.join(SUPPORTED)}, not {scenario!r}")
    if holdout is not None and scenario not in STAGES:
        raise BadInput(
            f"--holdout {holdout}: for the stages ({', '.join(STAGES)}); discover {scenario} holds out "
            "its own folds (an arm's and a platform's contiguous blocks, a scanner's turns)"
        )

    def once(config):
        """discovery.json's content and the figure's data, the recording replayed by the twin of
        ``config`` (None: the scenario's nominal twin)."""
        if scenario == "probe-scanner":
            from calibench.recordings import load_scanner_csv
            from calibench.scenarios.config import load_toml, override
            from calibench.scenarios.discover.probe_scanner import discover_scanner
            from calibench.scenarios.probe_scanner.scenario import ProbeScannerConfig

            cfg = ProbeScannerConfig()
            if config is not None:
                cfg = override(cfg, load_toml(config).get("probe-scanner", {}), "probe-scanner")
            return discover_scanner(load_scanner_csv(paths[0], MAX_ROWS), seed, config=cfg)
        if scenario == "stewart":
            from calibench.recordings import load_stewart_csv
            from calibench.scenarios.config import load_toml, override
            from calibench.scenarios.discover.stewart import discover_stewart
            from calibench.scenarios.stewart.scenario import StewartConfig

            cfg = StewartConfig()
            if config is not None:
                cfg = override(cfg, load_toml(config).get("stewart", {}), "stewart")
            return discover_stewart(load_stewart_csv(paths[0], MAX_ROWS), seed, config=cfg)
        if scenario == "arm-cmm":
            from calibench.scenarios.discover.twin import arm_truth
            from calibench.scenes.arm_cmm import load_arm

            if arm is not None and not str(arm).strip():
                raise BadInput(
                    "--arm is empty: give an ARM.toml or a built-in arm's name (arm-cmm, ur10)"
                )
            description = load_arm(arm or "arm-cmm")
            recs = [
                load_arm_csv(p, description.n_joints, MAX_ROWS, np.degrees(description.range_rad))
                for p in paths
            ]
            out, fig = discover_arm(
                recs if len(recs) > 1 else recs[0],
                seed,
                arm=description,
                truth=arm_truth(description, config),
            )
            if len(paths) > 1:
                out["recordings"] = [str(p) for p in paths]
            return out, fig
        from calibench.scenarios.discover.twin import stage_truth

        return discover_stage(
            scenario,
            load_stage_csv(paths[0], MAX_ROWS),
            seed,
            holdout,
            truth=stage_truth(scenario, config),
        )

    out, fig = once(config)
    before = None
    if config is not None:  # the nominal twin's residual beside the updated one's, both replayed
        out["replayed_config"] = str(config)
        nominal, before = once(None)
        out["nominal_twin_fit"] = nominal["fit"]
    if twin is not None:
        from calibench.scenarios.discover.twin import twin_tables

        tables, left = twin_tables(scenario, out, config, arm)
        note = f"the twin of {paths[0]} updated by calibench discover"
        if left:
            note += "; not carried by the simulation: " + ", ".join(left)
        write_toml(twin, tables, note)
        out["twin"] = {"path": str(twin), "not_carried": left}
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / "discovery.json").write_text(json.dumps(out, indent=2, default=_json_default) + "\n")
    _figure(out_dir / "discovery.png", out, fig, before)
    return out


def write_toml(path: Path, tables: dict, comment: str) -> None:
    """A config file (nested tables of numbers and lists of numbers) for ``run --config``."""

    def value(v):
        if isinstance(v, (list, tuple)):
            return "[" + ", ".join(value(x) for x in v) + "]"
        return repr(int(v)) if isinstance(v, (int, np.integer)) else repr(float(v))

    lines = [f"# {comment}"]

    def table(prefix, d):
        plain = {k: v for k, v in d.items() if not isinstance(v, dict)}
        if plain:
            lines.append(f"\n[{prefix}]")
            lines.extend(f"{k} = {value(v)}" for k, v in plain.items())
        for k, v in d.items():
            if isinstance(v, dict):
                table(f"{prefix}.{k}", v)

    for name, d in tables.items():
        table(name, d)
    try:
        Path(path).write_text("\n".join(lines) + "\n")
    except OSError as e:
        raise BadInput(f"cannot write the twin {path}: {e.strerror}") from None


def _json_default(o):
    if isinstance(o, (np.floating, np.integer)):
        return o.item()
    raise TypeError(type(o))


def _figure(path: Path, out: dict, fig: dict, before_fig: dict | None = None) -> None:
    """Residuals before (the scene model alone) and after (with the accepted effects); with
    ``before_fig`` (a replay by an updated twin), the nominal twin's residual and the updated
    twin's, both simulated (the scene model alone)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    sigs = fig["signals"]
    f, axes = plt.subplots(
        len(sigs), 2, figsize=(13, 3.6 * len(sigs)), squeeze=False, constrained_layout=True
    )

    def alone(sig):
        return sig.r - sig.base @ lstsq(sig.base, sig.r) if sig.base.shape[1] else sig.r

    titles = ("scene model only", "with the accepted effects")
    for k, (row, s) in enumerate(zip(axes, sigs)):
        before = alone(s)
        after = fig["fitted"][s.axis]
        if before_fig is not None:
            before, after = alone(before_fig["signals"][k]), before
            titles = ("the nominal twin, replayed", "the updated twin, replayed")
        if "x" in fig and s.u is not None:
            for ax, v, title in ((row[0], before, titles[0]), (row[1], after, titles[1])):
                lim = np.max(np.abs(before)) * 1000
                sc = ax.scatter(
                    fig["x"], fig["y"], c=v * 1000, s=6, cmap="coolwarm", vmin=-lim, vmax=lim
                )
                ax.set(
                    title=f"{s.name}: {title}, rms {np.sqrt(np.mean(v**2)) * 1000:.2f} um",
                    xlabel="x (mm)",
                    ylabel="y (mm)",
                )
                f.colorbar(sc, ax=ax, label="um")
        else:
            u, label = fig.get("abscissa") or (
                np.arange(len(before)),
                "row (posture x 3 + coordinate)",
            )
            for ax, v, title in ((row[0], before, titles[0]), (row[1], after, titles[1])):
                ax.plot(u, v * 1000, ".", ms=2)
                ax.set(
                    title=f"{s.name}: {title}, rms {np.sqrt(np.mean(v**2)) * 1000:.2f} um",
                    xlabel=label,
                    ylabel="um",
                )
    f.suptitle(
        f"{out['scenario']}: "
        + ("replayed with the updated twin; " if before_fig is not None else "")
        + (", ".join(f"{e['name']} ({e['axis']})" for e in out["effects"]) or "nothing missing")
    )
    f.savefig(path, dpi=80)
    plt.close(f)
