"""``calibench fit arm-cmm``: calibrate any serial arm on measured points, and say how well the
result carries to other recordings.

Training recordings each get their own base registration; the kinematic parameters, the tool
point and (``--model physics``) the joints' compliance under gravity are shared. The order of
work, each step on what the previous left:

1. screen every recording without a model (stale readings, repeats that disagree);
2. register each base and the tool point on the nominal arm (the laser-tracker seed's base and
   Tool0 calibration), then find the identifiable parameters at that state and solve for them,
   each kinematic error with a prior of its typical size (``PRIOR``);
3. weight: the instrument's stated sigma plus a model-error variance per recording estimated
   from its residuals (so the reported std mean what they say, and a setup the model fits worse
   weighs less), and refit;
4. leave out training rows whose residual no Gaussian scatter of their recording's size
   explains (p < 1e-6);
5. test: ``--test`` recordings in the first training recording's frame, ``--test-new-frame``
   recordings registered on 20 % of their rows (a fixed seed) and judged on the rest,
   ``--holdout`` rows of the training recordings; and warn where the training postures leave
   out part of the workspace.

Writes DIR/fit.json (CONTRACT, "fit arm-cmm") and DIR/fit.png.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np

from calibench.estimators.arm.kinematics import gravity_torques, parallel_axes_note, param_is_angle
from calibench.estimators.arm.point import AngleTerm, PointProblem
from calibench.estimators.arm.screening import screen
from calibench.estimators.identification.basis import Basis, identifiable_basis
from calibench.estimators.identification.solver import identify
from calibench.estimators.rotations import matrix_to_rotvec, rigid_transform
from calibench.recordings import ArmRecording, load_arm_csv
from calibench.scenarios.arm_cmm.arms import chain_of, load_arm, loaded_joints
from calibench.scenarios.report import BadInput

SPLIT_SEED = 0  # holdout rows and new-frame registration rows: fixed, so runs compare
REGISTER_FRACTION = 0.2
OUTLIER_P = 1e-6
MAX_ROWS = 500_000  # the Jacobian (3 rows x ~50 columns a posture) stays under 1 GB
# The kinematic errors' prior, in their typical sizes (0.1 mm, 1 mrad): a machined arm's
# tolerances. On the UR10 trained on its random poses (ur10_C) it is what carries the fit to the
# other side of the robot (held-out ur10_B: 0.63 mm without, 0.49 with); on enough data it
# changes nothing (all four series: the same figures to 0.001 mm).
PRIOR = 1.0


@dataclasses.dataclass
class ArmCalibration:
    """A fitted arm: the problem (postures, frames), the identification, what was left out."""

    problem: PointProblem
    ident: object
    model: str
    compliance_dropped: dict
    outliers: np.ndarray  # indices into the problem's rows that were left out of the last fit
    sigma_model_mm: float
    names: tuple

    @property
    def state(self):
        """The identification's final state."""
        return self.ident.state


def calibrate(
    chain,
    q_rad: np.ndarray,
    xyz_mm: np.ndarray,
    recording: np.ndarray,
    sigma_mm: np.ndarray | None,
    model: str,
    parallel=(),
    robust: bool = True,
    prior: float | None = PRIOR,
    angle_terms=(),
) -> ArmCalibration:
    """Steps 2-4 of the module's recipe on stacked rows (q (n, N), xyz (n, 3), recording (n,)).
    ``prior``: the kinematic errors' prior in units of their typical size (None: none);
    ``angle_terms``: joint-angle errors a discovery found (:func:`angle_terms_from_discovery`).
    A singular system (an arm whose links have no length, postures that never move the tool
    point) is bad input, said in one line."""
    try:
        return _calibrate(
            chain, q_rad, xyz_mm, recording, sigma_mm, model, parallel, robust, prior, angle_terms
        )
    except np.linalg.LinAlgError:
        raise BadInput(
            "the postures and the arm leave the fit singular: the measured points cannot determine "
            "even the base frame and the tool (an arm without length? postures that never move the "
            "tool point?)"
        ) from None


def _calibrate(
    chain, q_rad, xyz_mm, recording, sigma_mm, model, parallel, robust, prior, angle_terms
) -> ArmCalibration:
    """:func:`calibrate`, its singular systems not yet said."""
    joints, why = loaded_joints(chain, q_rad) if model == "physics" else ((), {})
    keep = np.ones(len(q_rad), bool)
    outliers = np.zeros(0, int)
    for _ in range(4):
        problem = PointProblem(
            chain,
            q_rad[keep],
            xyz_mm[keep],
            recording[keep],
            None if sigma_mm is None else sigma_mm[keep],
            compliance_joints=joints,
            prior=prior,
            angle_terms=angle_terms,
        )
        held = problem.held_tool()
        n_par = len(problem.names)
        if 3 * keep.sum() <= n_par + 3:
            raise BadInput(
                f"{keep.sum()} postures for {n_par} parameters (base frames, tool, kinematics): "
                "far too few to calibrate"
            )
        reg = identify(problem, Basis(np.sort(problem.always), {}))
        # what the data determine, without the prior (which would make everything "identifiable")
        problem.prior = None
        basis = identifiable_basis(problem, reg.state, note=parallel_axes_note(list(parallel)))
        problem.prior = prior
        ident = identify(problem, basis, reg.state)
        sigma = 0.0
        for _ in range(2):
            sigma = problem.reweight(ident.state, 3 * keep.sum() - len(basis.kept))
            ident = identify(problem, basis, ident.state)
        if not robust:
            break
        # rows no Gaussian scatter of the fitted size explains: |e|^2 / s^2 beyond chi2(3)'s 1 - 1e-6
        e = (problem.y - problem.model(ident.state)) * problem.weights()
        d2 = np.sum(e * e, axis=1)
        # each recording against its own scatter (chi2(3)'s median is 2.366)
        s2 = np.array([np.median(d2[problem.rec == r]) for r in range(problem.n_rec)]) / 2.366
        bad = d2 > 30.66 * s2[problem.rec]
        if not bad.any():
            break
        rows = np.flatnonzero(keep)
        outliers = np.r_[outliers, rows[bad]]
        keep[rows[bad]] = False
    return ArmCalibration(
        problem, ident, model, {**why, **held}, np.sort(outliers), sigma, problem.names
    )


def angle_terms_from_discovery(path, n_joints: int, n_recordings: int = 1) -> list[AngleTerm]:
    """The joint-angle effects of a ``discover arm-cmm`` result (a discovery.json's path, or its
    content) as terms of the fit: transmission harmonics, encoder eccentricity, a nonsmooth table
    over a joint's angle. A transmission with ``"per_recording": true`` gets its own phase and
    amplitude in each of the ``n_recordings`` training recordings (a motor-side error whose phase
    to the joint's angle is set at each power-up)."""
    if isinstance(path, dict):
        d, path = path, "the discovery"
    elif not str(path).strip():
        raise BadInput("--effects is empty: give a discovery.json, or discover")
    else:
        try:
            d = json.loads(Path(path).read_text())
        except OSError as e:
            raise BadInput(f"cannot read {path}: {e.strerror}") from None
        except (json.JSONDecodeError, UnicodeDecodeError):
            raise BadInput(f"{path} is not a discovery.json (not JSON)") from None
    if (
        not isinstance(d, dict)
        or d.get("scenario") != "arm-cmm"
        or not isinstance(d.get("effects"), list)
    ):
        raise BadInput(f"{path} is not the discovery.json of an arm-cmm recording")
    terms = []
    for k, e in enumerate(d["effects"]):
        if not isinstance(e, dict) or not isinstance(e.get("params", {}), dict):
            raise BadInput(f"{path}: effect {k + 1} is not an object with a name and its params")
        name, p = e.get("name"), e.get("params", {})
        if name not in ARM_EFFECTS:
            raise BadInput(
                f"{path}: effect {name!r} is not an arm's (the arm's effects: {', '.join(ARM_EFFECTS)})"
            )
        if name not in ("transmission", "encoder_eccentricity", "nonsmooth"):
            continue  # the model's own (geometry, compliance) or none the fit has a term for
        j = p.get("joint")
        if isinstance(j, bool) or not isinstance(j, int) or not 1 <= j <= n_joints:
            raise BadInput(
                f"{path}: effect {name} names joint {j!r}; the arm has {n_joints} joints"
            )
        if name == "transmission":
            if not isinstance(p.get("per_recording", False), bool):
                raise BadInput(
                    f"{path}: per_recording of joint {j}'s transmission is true or false, "
                    f"not {p['per_recording']!r}"
                )
            recs = range(n_recordings) if p.get("per_recording") else [None]
            harmonics = _numbers(
                p.get("harmonics", []), f"{path}: joint {j}'s transmission harmonics", 0.0, 1e3
            )
            terms += [
                AngleTerm(j, "harmonic", harmonic=h, label="transmission", recording=r)
                for h in harmonics
                for r in recs
            ]
        elif name == "encoder_eccentricity":
            terms.append(AngleTerm(j, "harmonic", harmonic=1.0, label="eccentricity"))
        elif "edges_deg" in p:
            edges_deg = _numbers(p["edges_deg"], f"{path}: joint {j}'s edges_deg", -3600.0, 3600.0)
            if np.any(np.diff(edges_deg) <= 0):
                raise BadInput(f"{path}: joint {j}'s edges_deg must increase")
            terms.append(
                AngleTerm(
                    j,
                    "table",
                    edges_rad=tuple(np.r_[-np.inf, np.radians(edges_deg), np.inf]),
                    label="table",
                )
            )
    return terms


# the effects a discover arm-cmm names (CONTRACT's effect names for an arm)
ARM_EFFECTS = (
    "geometry",
    "joint_compliance",
    "encoder_eccentricity",
    "thermal_expansion",
    "transmission",
    "nonsmooth",
)


def _numbers(values, what: str, lo: float, hi: float) -> list[float]:
    """A JSON list of plain numbers in (lo, hi], or one BadInput line saying what it holds."""
    if not isinstance(values, list) or not all(
        isinstance(v, (int, float)) and not isinstance(v, bool) for v in values
    ):
        raise BadInput(f"{what}: a list of numbers, not {values!r}")
    out = [float(v) for v in values]
    if not all(lo < v <= hi for v in out):
        raise BadInput(f"{what}: each between {lo:g} and {hi:g}, not {values!r}")
    return out


def _unit_and_factor(name: str) -> tuple[str, float]:
    if name.startswith("angle_"):
        return "urad", 1e6
    if name.startswith(("compliance", "tilt_compliance")):
        return "urad_per_nm", 1e6
    if param_is_angle([name])[0] or name.startswith("base_r"):
        return "urad", 1e6
    return "mm", 1.0


def _errors(e: np.ndarray) -> dict:
    d = np.linalg.norm(e, axis=1)
    return {
        "samples": int(len(d)),
        "mean_mm": float(d.mean()),
        "rms_mm": float(np.sqrt(np.mean(d * d))),
        "max_mm": float(d.max()),
        "p95_mm": float(np.percentile(d, 95)),
    }


def _arcs(q_deg: np.ndarray, bin_deg: float = 10.0) -> np.ndarray:
    """Which 10-degree bins of each joint's angle (mod 360) the postures visit, (N, 36) bool."""
    b = (np.mod(q_deg, 360.0) // bin_deg).astype(int)
    out = np.zeros((q_deg.shape[1], int(360 / bin_deg)), bool)
    for j in range(q_deg.shape[1]):
        out[j, np.unique(b[:, j])] = True
    return out


def _span_deg(q_deg: np.ndarray) -> float:
    """The arc (deg) a joint's angles cover: 360 minus the largest gap between them, mod 360."""
    a = np.sort(np.mod(q_deg, 360.0))
    gaps = np.diff(np.r_[a, a[0] + 360.0])
    return float(360.0 - gaps.max())


def coverage_warnings(
    chain, q_train: np.ndarray, tests: dict[str, np.ndarray], compliance_joints
) -> list[str]:
    """Where the training postures leave out part of the workspace that a test visits, or that a
    model would need to see (one sign of a joint's gravity torque, a narrow band of a joint)."""
    out = []
    qd = np.degrees(q_train)
    for j in range(qd.shape[1]):
        span = _span_deg(qd[:, j])
        if span < 180.0:
            out.append(f"q{j + 1} spans only {span:.0f} deg in the training postures")
    tau = gravity_torques(chain, q_train) if chain.has_masses else None
    for j in compliance_joints:
        pos = float(np.mean(tau[:, j - 1] > 0))
        if pos < 0.02 or pos > 0.98:
            sign = "positive" if pos > 0.5 else "negative"
            out.append(
                f"joint {j}'s gravity torque is {sign} in {100 * max(pos, 1 - pos):.0f} % of the training "
                "postures: the model has not seen it loaded the other way"
            )
    arcs = _arcs(qd)
    for name, q in tests.items():
        qt = np.degrees(q)
        b = (np.mod(qt, 360.0) // 10.0).astype(int)
        for j in range(qt.shape[1]):
            outside = float(np.mean(~arcs[j, b[:, j]]))
            if outside > 0.1:
                out.append(
                    f"{name}: {100 * outside:.0f} % of its postures put q{j + 1} where no training posture has it"
                )
        if tau is not None:
            tt = gravity_torques(chain, q)
            for j in compliance_joints:
                train_pos = np.mean(tau[:, j - 1] > 0)
                if train_pos < 0.02 or train_pos > 0.98:
                    other = float(np.mean((tt[:, j - 1] > 0) != (train_pos > 0.5)))
                    if other > 0.1:
                        out.append(
                            f"{name}: {100 * other:.0f} % of its postures load joint {j} the other way"
                        )
    return out


def _labels(paths: list[Path]) -> dict[Path, str]:
    """Each recording's name in fit.json and residuals.csv: its file name, or as many of its last
    path parts as tell it from another recording of the same name (setup1/data.csv). The same
    file given twice is refused."""
    resolved = [p.resolve() for p in paths]
    twice = sorted({str(p) for p in paths if resolved.count(p.resolve()) > 1})
    if twice:
        raise BadInput(f"{twice[0]} is given twice among the recordings: give each recording once")
    labels = {}
    for p, r in zip(paths, resolved):
        k = 1
        while sum(o.parts[-k:] == r.parts[-k:] for o in resolved) > 1:
            k += 1
        labels[p] = "/".join(r.parts[-k:])
    return labels


def _load(path: Path, arm) -> ArmRecording:
    return load_arm_csv(path, arm.n_joints, MAX_ROWS, np.degrees(arm.range_rad))


def _screened(rec: ArmRecording) -> tuple[np.ndarray, list[dict], list[tuple[int, int, float]]]:
    """Rows kept after the model-free screening, what was flagged, and the disagreeing pairs
    left for a model to settle."""
    s = screen(rec.q_rad, rec.xyz_mm)
    keep = np.ones(len(rec), bool)
    flagged = []
    for r in s.stale:
        keep[r] = False
        flagged.append(
            {
                "row": int(r),
                "why": "stale: repeats the previous row's measurement while the arm moved",
            }
        )
    pairs = []
    for (a, b), d in zip(s.pairs, s.distance_mm):
        if keep[a] and keep[b]:
            pairs.append((int(a), int(b), float(d)))
    return keep, flagged, pairs, s.repeatability_mm


def _settle_pairs(keep, flagged, pairs, model_xyz, meas_xyz, repeat_mm):
    """Of each disagreeing pair, leave out the row farther from the model."""
    for a, b, d in pairs:
        ea, eb = (np.linalg.norm(model_xyz[i] - meas_xyz[i]) for i in (a, b))
        bad, good = (a, b) if ea > eb else (b, a)
        keep[bad] = False
        flagged.append(
            {
                "row": bad,
                "why": f"the same posture as row {good}, measured {d:.2f} mm away from it "
                f"(repeatability {repeat_mm:.3f} mm); this one is the farther from the model",
            }
        )


def run_arm_fit(
    paths: list[Path],
    arm_spec: str | Path | None,
    tests: list[Path],
    tests_new_frame: list[Path],
    holdout: float | None,
    model: str | None,
    out_dir: Path,
    effects: Path | str | None = None,
) -> dict:
    """The ``fit arm-cmm`` command: fit.json's content (also written to ``out_dir``). ``effects``:
    a discovery.json whose joint-angle effects join the model, or ``"discover"``: run the
    discovery here, on the training rows only (held-out rows never shape the model)."""
    if arm_spec is not None and not str(arm_spec).strip():
        raise BadInput("--arm is empty: give an ARM.toml or a built-in arm's name (arm-cmm, ur10)")
    arm = load_arm(arm_spec or "arm-cmm")
    run_discovery = str(effects) == "discover"
    terms = (
        angle_terms_from_discovery(effects, arm.n_joints, len(paths))
        if effects is not None and not run_discovery
        else []
    )
    if model is None:
        model = "physics" if arm.has_masses else "geometry"
    if model == "physics" and not arm.has_masses:
        raise BadInput(
            f"--model physics needs the arm's masses (mass_kg and com_mm per joint in {arm.source})"
        )
    if holdout is not None and not 0.0 < holdout < 0.9:
        raise BadInput(f"--holdout {holdout}: a fraction between 0 and 0.9")
    label = _labels(paths + tests + tests_new_frame)
    chain = chain_of(arm)
    train = [_load(p, arm) for p in paths]
    judged = {
        p: _load(p, arm) for p in tests + tests_new_frame
    }  # read now: a bad one is said before the fit
    rng = np.random.default_rng(SPLIT_SEED)
    flagged, pending, held, used = {}, {}, {}, []
    for p, rec in zip(paths, train):
        keep, fl, pairs, rep = _screened(rec)
        flagged[label[p]], pending[label[p]] = fl, (pairs, rep)
        if holdout:
            idx = rng.permutation(len(rec))
            out = np.zeros(len(rec), bool)
            out[idx[: int(round(holdout * len(rec)))]] = True
            if not (out & keep).any():
                raise BadInput(
                    f"--holdout {holdout:g} holds out no usable row of {p} ({len(rec)} rows)"
                )
            held[label[p]] = out & keep
            keep &= ~out
        used.append(keep)
    for p, keep in zip(paths, used):
        if keep.sum() < 3:
            raise BadInput(f"{p}: {keep.sum()} usable rows; a base registration needs at least 3")
    q = np.vstack([r.q_rad[k] for r, k in zip(train, used)])
    y = np.vstack([r.xyz_mm[k] for r, k in zip(train, used)])
    rec_id = np.concatenate([np.full(k.sum(), i) for i, k in enumerate(used)])
    sig = None
    if all(r.xyz_std_mm is not None for r in train):
        sig = np.vstack([r.xyz_std_mm[k] for r, k in zip(train, used)])
    check_postures(q, len(paths))
    discovery = None
    if run_discovery:
        from calibench.scenarios.discover.command import discover_arm

        parts = [r.subset(k) for r, k in zip(train, used)]
        discovery, _ = discover_arm(parts if len(parts) > 1 else parts[0], arm=arm)
        terms = angle_terms_from_discovery(discovery, arm.n_joints, len(paths))
    cal = calibrate(chain, q, y, rec_id, sig, model, arm.parallel_pairs(), angle_terms=terms)
    # settle the training recordings' disagreeing pairs with the fitted model, refit if any
    rows_of = np.concatenate([np.flatnonzero(k) for k in used])
    if any(pending[label[p]][0] for p in paths):
        for i, (p, rec) in enumerate(zip(paths, train)):
            pairs, rep = pending[label[p]]
            if pairs:
                _settle_pairs(
                    used[i],
                    flagged[label[p]],
                    pairs,
                    cal.problem.model(cal.state, rec.q_rad, frame=i, session=i),
                    rec.xyz_mm,
                    rep,
                )
        q = np.vstack([r.q_rad[k] for r, k in zip(train, used)])
        y = np.vstack([r.xyz_mm[k] for r, k in zip(train, used)])
        rec_id = np.concatenate([np.full(k.sum(), i) for i, k in enumerate(used)])
        sig = None if sig is None else np.vstack([r.xyz_std_mm[k] for r, k in zip(train, used)])
        cal = calibrate(chain, q, y, rec_id, sig, model, arm.parallel_pairs(), angle_terms=terms)
        rows_of = np.concatenate([np.flatnonzero(k) for k in used])
    # model-based outliers of the training rows, by file
    for i_row in cal.outliers:
        i_rec = int(rec_id[i_row])
        flagged[label[paths[i_rec]]].append(
            {
                "row": int(rows_of[i_row]),
                "why": "its residual is beyond any Gaussian scatter of the fit's size "
                "(p < 1e-6): left out of the fit",
            }
        )
    s = cal.state
    prob = cal.problem
    e_fit = prob.y - prob.model(s)
    result = {
        "scenario": "arm-cmm",
        "arm": arm.name,
        "model": model,
        "samples": int(len(prob.y)),
        "parameters": [],
        "dropped": [],
        "converged": bool(cal.ident.converged),
    }
    if effects is not None:
        result["effects_from"] = {
            "file": "discovery on the training rows" if run_discovery else str(effects),
            "terms": [t.names[0].rsplit("_", 1)[0] for t in terms],
        }
        if discovery is not None:
            result["effects_from"]["summary"] = discovery["summary"]
    for name in (prob.names[k] for k in cal.ident.basis.kept):
        if name.startswith("base_"):
            continue
        unit, f = _unit_and_factor(name)
        result["parameters"].append(
            {
                "name": name,
                "unit": unit,
                "estimate": cal.ident.estimate[name] * f,
                "std": cal.ident.std[name] * f,
            }
        )
    result["dropped"] = [
        {"name": k, "why": v}
        for k, v in {**cal.ident.basis.dropped, **cal.compliance_dropped}.items()
    ]
    bases = {}
    for i, p in enumerate(paths):
        bases[label[p]] = {
            "translation_mm": s.t[i].tolist(),
            "rotvec_rad": matrix_to_rotvec(s.R[i]).tolist(),
        }
    result["base"] = bases[label[paths[0]]]
    result["bases"] = bases
    result["tool_mm"] = (np.asarray(chain.tool_mm) + s.delta[-3:]).tolist()
    fit_fig = _errors(e_fit)
    result["fit"] = {k: fit_fig[k] for k in ("mean_mm", "rms_mm", "max_mm")}
    result["sigma_model_mm"] = cal.sigma_model_mm
    extra = np.broadcast_to(np.asarray(prob.extra_var, float), (len(paths),))
    result["sigma_model_mm_by_recording"] = {
        label[p]: float(np.sqrt(v)) for p, v in zip(paths, extra)
    }
    figures = {"training": np.linalg.norm(e_fit, axis=1)}
    residuals = []  # (file, row, role, measured - modelled (n, 3))
    outlier_rows = np.zeros(len(q), bool)
    outlier_rows[cal.outliers] = True
    for i, p in enumerate(paths):
        mine = rec_id == i
        kept = mine & ~outlier_rows
        residuals.append((label[p], rows_of[kept], "train", None))
        if outlier_rows[mine].any():
            rows = rows_of[mine & outlier_rows]
            residuals.append(
                (
                    label[p],
                    rows,
                    "left_out",
                    train[i].xyz_mm[rows] - prob.model(s, train[i].q_rad[rows], frame=i, session=i),
                )
            )
    if holdout:
        result["holdout"] = {}
        for i, (p, rec) in enumerate(zip(paths, train)):
            m = held[label[p]].copy()
            # a row named bad (the farther of a disagreeing repeat) is not judged, as in a test recording
            m[[f["row"] for f in flagged[label[p]]]] = False
            if m.sum() == 0:
                continue
            e = prob.model(s, rec.q_rad[m], frame=i, session=i) - rec.xyz_mm[m]
            result["holdout"][label[p]] = {**_errors(e), "fraction": holdout}
            residuals.append((label[p], np.flatnonzero(m), "holdout", -e))
            figures[f"{label[p]} (held out)"] = np.linalg.norm(e, axis=1)
    tested = {}
    if tests or tests_new_frame:
        result["test"] = {}
    for p in tests:
        rec = judged[p]
        keep, fl, pairs, rep = _screened(rec)
        _enough_to_judge(p, keep)
        _settle_pairs(keep, fl, pairs, prob.model(s, rec.q_rad, frame=0), rec.xyz_mm, rep)
        e = prob.model(s, rec.q_rad[keep], frame=0) - rec.xyz_mm[keep]
        result["test"][label[p]] = {**_errors(e), "frame": f"{label[paths[0]]}'s"}
        residuals.append((label[p], np.flatnonzero(keep), "test", -e))
        flagged[label[p]] = fl
        figures[label[p]] = np.linalg.norm(e, axis=1)
        tested[label[p]] = rec.q_rad
    for p in tests_new_frame:
        rec = judged[p]
        keep, fl, pairs, rep = _screened(rec)
        _enough_to_judge(p, keep)
        base_pts = prob.base_points(s, rec.q_rad)
        order = np.random.default_rng(SPLIT_SEED).permutation(np.flatnonzero(keep))
        k_reg = max(int(round(REGISTER_FRACTION * len(order))), 3)
        reg_rows, eval_rows = order[:k_reg], np.sort(order[k_reg:])
        if len(eval_rows) == 0:
            raise BadInput(
                f"{p}: {len(order)} usable rows; a new frame needs rows to register on and rows to judge"
            )
        sv = np.linalg.svd(
            rec.xyz_mm[reg_rows] - rec.xyz_mm[reg_rows].mean(axis=0), compute_uv=False
        )
        if sv[1] < max(1e-3 * sv[0], 1.0):
            raise BadInput(
                f"{p}: the {len(reg_rows)} rows a new frame is registered on measure points on one line "
                "(or one point): they cannot fix the frame's rotation"
            )
        R, t = rigid_transform(base_pts[reg_rows], rec.xyz_mm[reg_rows])
        model_xyz = base_pts @ R.T + t
        ev = np.zeros(len(rec), bool)
        ev[eval_rows] = True
        _settle_pairs(
            ev, fl, [pr for pr in pairs if ev[pr[0]] and ev[pr[1]]], model_xyz, rec.xyz_mm, rep
        )
        e = model_xyz[ev] - rec.xyz_mm[ev]
        residuals.append(
            (label[p], reg_rows, "register", rec.xyz_mm[reg_rows] - model_xyz[reg_rows])
        )
        residuals.append((label[p], np.flatnonzero(ev), "test", -e))
        result["test"][label[p]] = {
            **_errors(e),
            "frame": f"registered on {len(reg_rows)} rows ({100 * REGISTER_FRACTION:.0f} %, "
            f"seed {SPLIT_SEED}), figures on the other {ev.sum()}",
        }
        flagged[label[p]] = fl
        figures[label[p]] = np.linalg.norm(e, axis=1)
        tested[label[p]] = rec.q_rad
    result["flagged"] = {k: v for k, v in flagged.items() if v}
    comp_joints = [int(n[len("compliance") :]) for n in prob.names if n.startswith("compliance")]
    result["coverage"] = {"warnings": coverage_warnings(chain, q, tested, comp_joints)}
    stated = [label[p] for p, r in zip(paths, train) if r.xyz_std_mm is not None]
    if stated and len(stated) < len(
        paths
    ):  # one weighting for all, or the recordings' weights would not compare
        result["coverage"]["warnings"].append(
            f"{', '.join(stated)} state{'s' if len(stated) == 1 else ''} a std per value, "
            f"{', '.join(label[p] for p in paths if label[p] not in stated)} not: the stated std are not used, every row "
            "is weighted by the fitted scatter of its recording"
        )
    if result["fit"]["rms_mm"] > PLAUSIBLE_RMS_MM:
        result["coverage"]["warnings"].insert(
            0,
            (
                f"the fit leaves {result['fit']['rms_mm']:.3g} mm RMS, far beyond any arm's or instrument's error: is "
                f"the arm description right (--arm; this fit used {arm.name}) and are the columns in degrees and mm?"
            ),
        )
    elif tests:
        # a plausible fit and a same-frame test hundreds of times off it: the test's tracker stood elsewhere
        for p in tests:
            got = result["test"][label[p]]["rms_mm"]
            if got > PLAUSIBLE_RMS_MM and got > 100 * result["fit"]["rms_mm"]:
                result["coverage"]["warnings"].insert(
                    0,
                    (
                        f"{label[p]}: {got:.4g} mm RMS off the fitted arm in {label[paths[0]]}'s frame: is it from another "
                        "setup? (--test-new-frame registers its own frame)"
                    ),
                )
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / "fit.json").write_text(json.dumps(result, indent=2) + "\n")
    _write_residuals(out_dir / "residuals.csv", residuals, e_fit)
    _figure(out_dir / "fit.png", result, figures)
    return result


def _write_residuals(path: Path, parts: list, e_train: np.ndarray) -> None:
    """residuals.csv: every row the fit modelled, as measured minus modelled (mm) in its
    recording's frame: ``file, row`` (0-based, the recording's order), ``role`` (train: in the
    fit; left_out: a training row the fit left out; holdout; register: a new frame's
    registration rows; test), ``ex_mm, ey_mm, ez_mm``. For analyses of what the model leaves
    out (periodic errors, drift along the row order)."""
    lines = ["file,row,role,ex_mm,ey_mm,ez_mm"]
    at = 0
    for name, rows, role, e in parts:
        if e is None:  # the training rows, in the order the fit stacked them
            e, at = e_train[at : at + len(rows)], at + len(rows)
        lines += [f"{name},{r},{role},{x:.6f},{y:.6f},{z:.6f}" for r, (x, y, z) in zip(rows, e)]
    path.write_text("\n".join(lines) + "\n")


PLAUSIBLE_RMS_MM = (
    10.0  # a calibrated arm's fit beyond this is a wrong description or wrong columns
)


def _enough_to_judge(path: Path, keep: np.ndarray) -> None:
    """A test recording needs rows left to judge the fit on once its stale readings are out."""
    if keep.sum() < 3:
        raise BadInput(
            f"{path}: {keep.sum()} usable rows of {len(keep)} once the stale readings (a measurement "
            "repeated while the arm moved) are left out: too few to judge the fit on"
        )


def check_postures(q: np.ndarray, n_recordings: int) -> None:
    """Degenerate posture sets are bad input: too few distinct postures, or one repeated."""
    distinct = len(np.unique(np.round(np.degrees(q), 2), axis=0))
    if distinct < 0.1 * len(q) and distinct < 50:
        raise BadInput(
            f"{len(q)} rows but only {distinct} distinct postures: repeats carry no new information "
            "for calibration"
        )
    if distinct < 10 + 6 * n_recordings:
        raise BadInput(f"{distinct} distinct postures: too few to calibrate the arm")


def _figure(path: Path, result: dict, figures: dict) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 4.5), constrained_layout=True)
    for label, d in figures.items():
        x = np.sort(d)
        ax.plot(
            x,
            np.arange(1, len(x) + 1) / len(x),
            label=f"{label}: mean {d.mean():.3f}, max {d.max():.2f} mm",
        )
    ax.set(
        xlabel="3-D error |measured - modelled| (mm)",
        ylabel="fraction of postures",
        title=f"fit arm-cmm, {result['arm']}, model {result['model']}",
    )
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.savefig(path, dpi=90)
    plt.close(fig)
