"""``calibench fit arm-cmm``: calibrate any serial arm on measured points, and say how well the
result carries to other recordings.

Training recordings each get their own base registration; the kinematic parameters, the tool
point and (``--model physics``) the joints' compliance under gravity are shared. The order of
work, each step on what the previous left:

1. screen every recording without a model (stale readings, repeats that disagree);
2. calibrate (:func:`calibench.estimators.arm.calibration.calibrate`): register each base and
   the tool point on the nominal arm, solve for the identifiable parameters with their prior,
   weight each recording by its own scatter and refit, leave out the rows no Gaussian scatter
   explains; then settle the repeats that disagree with the fitted model, and refit if any;
3. test: ``--test`` recordings in the first training recording's frame, ``--test-new-frame``
   recordings registered on 20 % of their rows (a fixed seed) and judged on the rest
   (:func:`~calibench.estimators.arm.calibration.register_frame`), ``--holdout`` rows of the
   training recordings; and warn where the training postures leave out part of the workspace
   (:func:`~calibench.estimators.arm.coverage.coverage_warnings`).

This module reads and checks the input, wires the estimators and writes DIR/fit.json
(docs/formats.md, "fit arm-cmm"), DIR/residuals.csv and DIR/fit.png.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from calibench.estimators.arm import calibration
from calibench.estimators.arm.calibration import (
    ArmCalibration,
    DegenerateFit,
    error_statistics,
    register_frame,
)
from calibench.estimators.arm.coverage import coverage_warnings
from calibench.estimators.arm.kinematics import param_is_angle
from calibench.estimators.arm.screening import screen
from calibench.estimators.arm.session import register_session, session_terms
from calibench.estimators.rotations import matrix_to_rotvec, rigid_transform
from calibench.recordings import ArmRecording, load_arm_csv
from calibench.scenarios.arm_cmm.arms import chain_of, load_arm
from calibench.scenarios.arm_cmm.effects import angle_terms_from_discovery
from calibench.scenarios.arm_cmm.figure import write_fit_figure
from calibench.scenarios.progress import staged
from calibench.scenarios.provenance import chose_by_effects, chose_or_none, entry, record_score
from calibench.scenarios.report import BadInput

SPLIT_SEED = 0  # holdout rows and new-frame registration rows: fixed, so runs compare
REGISTER_FRACTION = 0.2
HOLDOUT_KIND = "random rows of a training session (interpolation within the sessions fitted)"
MAX_ROWS = 500_000  # the Jacobian (3 rows x ~50 columns a posture) stays under 1 GB


def calibrate(*args, **kwargs) -> ArmCalibration:
    """:func:`calibench.estimators.arm.calibration.calibrate` (the same arguments: q (n, N) rad,
    xyz (n, 3) mm, recording (n,), sigma (n, 3) mm or None), data it cannot determine said as
    bad input in one line (an arm whose links have no length, postures that never move the tool
    point, too few postures)."""
    with staged("calibrating"):  # the minutes of a fit on thousands of postures
        try:
            return calibration.calibrate(*args, **kwargs)
        except DegenerateFit as e:
            raise BadInput(str(e)) from None


def _unit_and_factor(name: str) -> tuple[str, float]:
    if name.startswith("angle_"):
        return "urad", 1e6
    if name.startswith(("compliance", "tilt_compliance", "cable_compliance")):
        return "urad_per_nm", 1e6
    if param_is_angle([name])[0] or name.startswith("base_r"):
        return "urad", 1e6
    return "mm", 1.0


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
    register_on_scored: bool = False,
) -> dict:
    """The ``fit arm-cmm`` command: fit.json's content (also written to ``out_dir``). ``effects``:
    a discovery.json whose joint-angle effects join the model, or ``"discover"``: run the
    discovery here, on the training rows only (held-out rows never shape the model).
    ``register_on_scored``: a new frame (and its session's terms) fitted by least squares on the
    rows that score it: the lowest RMS any registration leaves there, written as in-sample (not
    a command-line option: a measurement, never a result)."""
    if arm_spec is not None and not str(arm_spec).strip():
        raise BadInput("--arm is empty: give an ARM.toml or a built-in arm's name (arm-cmm, ur10)")
    arm = load_arm(arm_spec or "arm-cmm")
    run_discovery = str(effects) == "discover"
    chosen_by = chose_by_effects(effects, run_discovery)
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
        from calibench.scenarios.discover.arm_cmm import discover_arm

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
    fit_fig = error_statistics(e_fit)
    result["fit"] = {k: fit_fig[k] for k in ("mean_mm", "rms_mm", "max_mm")}
    result["sigma_model_mm"] = cal.sigma_model_mm
    extra = np.broadcast_to(np.asarray(prob.extra_var, float), (len(paths),))
    result["sigma_model_mm_by_recording"] = {
        label[p]: float(np.sqrt(v)) for p, v in zip(paths, extra)
    }
    # each curve says what its rows are: the fit's own (in-sample) or rows it never saw
    figures = {"training rows (in-sample)": np.linalg.norm(e_fit, axis=1)}
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
    scored: dict = {}  # by path, the rows scored and, in a new frame, those registered
    registered: dict = {}
    if holdout:
        result["holdout"] = {}
        for i, (p, rec) in enumerate(zip(paths, train)):
            m = held[label[p]].copy()
            # a row named bad (the farther of a disagreeing repeat) is not judged, as in a test
            # recording
            m[[f["row"] for f in flagged[label[p]]]] = False
            if m.sum() == 0:
                continue
            e = prob.model(s, rec.q_rad[m], frame=i, session=i) - rec.xyz_mm[m]
            figs = {**error_statistics(e), "fraction": holdout, "kind": HOLDOUT_KIND}
            record_score(
                result, "holdout", label[p], figs, np.flatnonzero(m), chosen_by(p, used[i])
            )
            scored[p] = np.flatnonzero(m)
            residuals.append((label[p], np.flatnonzero(m), "holdout", -e))
            figures[f"{label[p]} (held out)"] = np.linalg.norm(e, axis=1)
    tested: dict = {}
    if tests or tests_new_frame:
        result["test"] = {}
    for p in tests:
        rec = judged[p]
        keep, fl, pairs, rep = _screened(rec)
        _enough_to_judge(p, keep)
        _settle_pairs(keep, fl, pairs, prob.model(s, rec.q_rad, frame=0), rec.xyz_mm, rep)
        e = prob.model(s, rec.q_rad[keep], frame=0) - rec.xyz_mm[keep]
        figs = {**error_statistics(e), "frame": f"{label[paths[0]]}'s"}
        record_score(result, "test", label[p], figs, np.flatnonzero(keep), chosen_by(p, None))
        scored[p] = np.flatnonzero(keep)
        residuals.append((label[p], np.flatnonzero(keep), "test", -e))
        flagged[label[p]] = fl
        figures[f"{label[p]} (test)"] = np.linalg.norm(e, axis=1)
        tested[label[p]] = rec.q_rad
    for p in tests_new_frame:
        rec = judged[p]
        keep, fl, pairs, rep = _screened(rec)
        _enough_to_judge(p, keep)
        base_pts = prob.base_points(s, rec.q_rad)
        try:
            frame = register_frame(base_pts, rec.xyz_mm, keep, REGISTER_FRACTION, SPLIT_SEED)
        except DegenerateFit as e:
            raise BadInput(f"{p}: {e}") from None
        reg_rows, eval_rows = frame.register_rows, frame.judge_rows
        model_xyz = base_pts @ frame.R.T + frame.t
        # the floor (register_on_scored): frame and own terms fitted on the scored rows
        # themselves, by least squares, so no registration leaves them a lower RMS
        own, on = {}, eval_rows if register_on_scored else reg_rows
        if session_terms(prob.terms):
            # what belongs to a session (a harmonic's phase set at power-up) is fitted beside its
            # frame on the registration rows, never on the rows that score it
            fitted, model_xyz = register_session(prob, s, rec.q_rad, rec.xyz_mm, on)
            own = {n: float(v) * 1e6 for n, v in zip(fitted.names, fitted.coef)}
        elif register_on_scored:
            R, t = rigid_transform(base_pts[on], rec.xyz_mm[on])
            model_xyz = base_pts @ R.T + t
        ev = np.zeros(len(rec), bool)
        ev[eval_rows] = True
        _settle_pairs(
            ev, fl, [pr for pr in pairs if ev[pr[0]] and ev[pr[1]]], model_xyz, rec.xyz_mm, rep
        )
        e = model_xyz[ev] - rec.xyz_mm[ev]
        if not register_on_scored:
            residuals.append(
                (label[p], reg_rows, "register", rec.xyz_mm[reg_rows] - model_xyz[reg_rows])
            )
        residuals.append(
            (label[p], np.flatnonzero(ev), "in_sample" if register_on_scored else "test", -e)
        )
        figs = {
            **error_statistics(e),
            "frame": f"registered on {len(reg_rows)} rows ({100 * REGISTER_FRACTION:.0f} %, "
            f"seed {SPLIT_SEED}), figures on the other {ev.sum()}",
        }
        if register_on_scored:
            figs["frame"] = f"registered on the {len(on)} rows it scores (in-sample: the floor)"
        if own:
            figs["session_terms_urad"] = own
            figs["frame"] += (
                f"; the session's own terms ({len(own)} coefficients) fitted on those rows too"
            )
        if register_on_scored:
            why = "its frame and own terms were fitted on these rows: a floor, not a result"
            result.setdefault("in_sample", {})[label[p]] = {**figs, "was": "test", "why": why}
        else:
            record_score(result, "test", label[p], figs, np.flatnonzero(ev), chosen_by(p, None))
        scored[p], registered[p] = np.flatnonzero(ev), on
        flagged[label[p]] = fl
        figures[f"{label[p]} (new frame: scored rows)"] = np.linalg.norm(e, axis=1)
        tested[label[p]] = rec.q_rad
    result["provenance"] = [
        entry(
            p,
            chose=chose_or_none(chosen_by, p, used[i]),
            fitted=rows_of[(rec_id == i) & ~outlier_rows],
            scored=scored.get(p, ()),
        )
        for i, p in enumerate(paths)
    ] + [
        entry(
            p,
            chose=chose_or_none(chosen_by, p, None),
            fitted=registered.get(p, ()),
            scored=scored.get(p, ()),
        )
        for p in tests + tests_new_frame
    ]
    result["flagged"] = {k: v for k, v in flagged.items() if v}
    comp_joints = [int(n[len("compliance") :]) for n in prob.names if n.startswith("compliance")]
    result["coverage"] = {"warnings": coverage_warnings(chain, q, tested, comp_joints)}
    stated = [label[p] for p, r in zip(paths, train) if r.xyz_std_mm is not None]
    if stated and len(stated) < len(
        paths
    ):  # one weighting for all, or the recordings' weights would not compare
        result["coverage"]["warnings"].append(
            f"{', '.join(stated)} state{'s' if len(stated) == 1 else ''} a std per value, "
            f"{', '.join(label[p] for p in paths if label[p] not in stated)} not: the stated std "
            "are not used, every row is weighted by the fitted scatter of its recording"
        )
    result["implausible"] = None
    if result["fit"]["rms_mm"] > PLAUSIBLE_RMS_MM:
        # a calibration cannot be this far off: the exit status says it failed (1), not only a
        # warning among others
        result["implausible"] = (
            f"the fit leaves {result['fit']['rms_mm']:.3g} mm RMS, far beyond any arm's or "
            "instrument's error: is "
            f"the arm description right (--arm; this fit used {arm.name}) and are the columns "
            "in degrees and mm?"
        )
        result["coverage"]["warnings"].insert(0, result["implausible"])
    elif tests:
        # a plausible fit and a same-frame test hundreds of times off it: the test's tracker stood
        # elsewhere
        for p in tests:
            got = result["test"][label[p]]["rms_mm"]
            if got > PLAUSIBLE_RMS_MM and got > 100 * result["fit"]["rms_mm"]:
                # a test score of metres is no validation: the exit status says so too
                said = (
                    f"{label[p]}: {got:.4g} mm RMS off the fitted arm in {label[paths[0]]}'s "
                    "frame: is it from another setup? (--test-new-frame registers its own frame)"
                )
                result["implausible"] = result["implausible"] or said
                result["coverage"]["warnings"].insert(0, said)
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / "fit.json").write_text(json.dumps(result, indent=2) + "\n")
    _write_residuals(out_dir / "residuals.csv", residuals, e_fit)
    write_fit_figure(out_dir / "fit.png", result, figures)
    return result


def _write_residuals(path: Path, parts: list, e_train: np.ndarray) -> None:
    """residuals.csv: every row the fit modelled, as measured minus modelled (mm) in its
    recording's frame: ``file, row`` (0-based, the recording's order), ``role`` (train: in the
    fit; left_out: a training row the fit left out; holdout; register: a new frame's
    registration rows; test; in_sample: scored rows a new frame was fitted on, the floor),
    ``ex_mm, ey_mm, ez_mm``. For analyses of what the model leaves
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
            f"{path}: {keep.sum()} usable rows of {len(keep)} once the stale readings (a "
            "measurement repeated while the arm moved) are left out: too few to judge the fit on"
        )


def check_postures(q: np.ndarray, n_recordings: int) -> None:
    """Degenerate posture sets are bad input: too few distinct postures, or one repeated."""
    distinct = len(np.unique(np.round(np.degrees(q), 2), axis=0))
    if distinct < 0.1 * len(q) and distinct < 50:
        raise BadInput(
            f"{len(q)} rows but only {distinct} distinct postures: repeats carry no new "
            "information for calibration"
        )
    if distinct < 10 + 6 * n_recordings:
        raise BadInput(f"{distinct} distinct postures: too few to calibrate the arm")
