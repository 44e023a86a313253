"""``calibench fit arm-cmm``: calibrate any serial arm on measured points, and say how well the
result carries to other recordings.

Training recordings each get their own base registration; the kinematic parameters, the tool
point and (``--model physics``) the joints' compliance under gravity are shared. The order of
work, each step on what the previous left:

1. screen every recording without a model (stale readings, repeats that disagree) and hold out
   ``--holdout`` rows (:mod:`~calibench.scenarios.arm_cmm.training`);
2. calibrate (:func:`calibench.estimators.arm.calibration.calibrate`): register each base and
   the tool point on the nominal arm, solve for the identifiable parameters with their prior,
   weight each recording by its own scatter and refit, leave out the rows no Gaussian scatter
   explains; then settle the repeats that disagree with the fitted model, and refit if any;
3. test (:mod:`~calibench.scenarios.arm_cmm.scoring`): ``--test`` recordings in the first
   training recording's frame, ``--test-new-frame`` recordings registered on 20 % of their rows
   (a fixed seed) and judged on the rest
   (:func:`~calibench.estimators.arm.calibration.register_frame`), ``--holdout`` rows of the
   training recordings; and warn where the training postures leave out part of the workspace
   (:func:`~calibench.estimators.arm.workspace.coverage_warnings`).

This module reads and checks the input, wires the steps and writes DIR/fit.json
(docs/formats.md, "fit arm-cmm"), DIR/residuals.csv and DIR/fit.png.
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Callable
from pathlib import Path

import numpy as np

from calibench.estimators.arm.calibration import ArmCalibration, error_statistics
from calibench.estimators.arm.kinematics import Chain, param_is_angle
from calibench.estimators.arm.point import PointProblem
from calibench.estimators.arm.terms import AngleTerm
from calibench.estimators.arm.workspace import coverage_warnings
from calibench.estimators.rotations import matrix_to_rotvec
from calibench.scenarios.arm_cmm import NAME
from calibench.scenarios.arm_cmm.arms import chain_of, load_arm
from calibench.scenarios.arm_cmm.effects import angle_terms_from_discovery
from calibench.scenarios.arm_cmm.figure import write_fit_figure
from calibench.scenarios.arm_cmm.scoring import (
    REGISTER_FRACTION,
    ResidualPart,
    Score,
    score_holdout,
    score_new_frame,
    score_same_frame,
)
from calibench.scenarios.arm_cmm.training import (
    MAX_ROWS,
    SPLIT_SEED,
    Stacked,
    TrainingRecording,
    calibrate_and_settle,
    check_postures,
    flag_outliers,
    load_recording,
    recording_labels,
    split_training,
)
from calibench.scenarios.provenance import chose_by_effects, chose_or_none, entry, record_score
from calibench.scenarios.report import BadInput
from calibench.scenes.arm_cmm import DEFAULT_ARM, ArmDescription
from calibench.writing import replaced, write_text

# what other modules read from here (sessions, the benchmarks, the README's figures)
__all__ = ["MAX_ROWS", "REGISTER_FRACTION", "SPLIT_SEED", "run_arm_fit"]

PLAUSIBLE_RMS_MM = 10.0  # a calibrated arm's fit beyond this is a wrong description or columns


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
    arm = arm_of(arm_spec)
    run_discovery = str(effects) == "discover"
    chosen_by = chose_by_effects(effects, run_discovery)
    terms = (
        angle_terms_from_discovery(effects, arm.n_joints, len(paths))
        if effects is not None and not run_discovery
        else []
    )
    model = model_of(model, arm)
    check_holdout(holdout)
    label = recording_labels(paths + tests + tests_new_frame)
    chain = chain_of(arm)
    train_recs = [load_recording(p, arm) for p in paths]
    # read now: a bad one is said before the fit
    judged = {p: load_recording(p, arm) for p in tests + tests_new_frame}
    training = split_training(paths, train_recs, label, holdout)
    check_postures(np.vstack([tr.rec.q_rad[tr.used] for tr in training]), len(paths))
    discovery = None
    if run_discovery:
        discovery, terms = discovered_terms(training, arm)
    cal, rows = calibrate_and_settle(training, arm, chain, model, terms)
    outliers = flag_outliers(training, cal, rows)
    prob, state = cal.problem, cal.state
    e_fit = prob.y - prob.model(state)
    said_effects = None if effects is None else effects_used(effects, terms, discovery)
    result = fit_summary(arm, model, cal, chain, training, e_fit, said_effects)
    out = FitOutputs(
        result,
        training_residuals(training, rows, outliers, cal),
        {"training rows (in-sample)": np.linalg.norm(e_fit, axis=1)},
        {tr.label: tr.screening.flagged for tr in training},
    )
    if holdout:
        result["holdout"] = {}
        for i, tr in enumerate(training):
            sc = score_holdout(prob, state, tr, i, holdout)
            if sc is not None:
                out.add(tr.path, tr.label, sc, chosen_by(tr.path, tr.used))
    if tests or tests_new_frame:
        result["test"] = {}
    for p in tests:
        sc = score_same_frame(prob, state, p, label[p], judged[p], training[0].label)
        out.add(p, label[p], sc, chosen_by(p, None), judged[p].q_rad)
    for p in tests_new_frame:
        sc = score_new_frame(prob, state, p, label[p], judged[p], register_on_scored)
        chose = None if sc.in_sample_why else chosen_by(p, None)
        out.add(p, label[p], sc, chose, judged[p].q_rad)
    result["provenance"] = provenance(
        training, rows, outliers, tests + tests_new_frame, out, chosen_by
    )
    result["flagged"] = {k: v for k, v in out.flagged.items() if v}
    result["coverage"] = {"warnings": coverage_said(chain, rows, out.tested, prob, training)}
    # a calibration this far off, or a test score of metres, is no result: the exit status says
    # so (1), not only a warning among others
    said = implausible(result, arm, [label[p] for p in tests], training[0].label)
    result["implausible"] = said[0] if said else None
    for sentence in said:
        result["coverage"]["warnings"].insert(0, sentence)
    out_dir.mkdir(parents=True, exist_ok=True)
    write_text(out_dir / "fit.json", json.dumps(result, indent=2) + "\n")
    write_residuals(out_dir / "residuals.csv", out.residuals, e_fit)
    with replaced(out_dir / "fit.png") as tmp:
        write_fit_figure(tmp, result, out.figures)
    return result


def arm_of(arm_spec: str | Path | None) -> ArmDescription:
    """The arm an ``--arm`` names (an ARM.toml or a built-in arm's name; the seed's by default)."""
    if arm_spec is not None and not str(arm_spec).strip():
        raise BadInput("--arm is empty: give an ARM.toml or a built-in arm's name (arm-cmm, ur10)")
    return load_arm(arm_spec or DEFAULT_ARM)


def model_of(model: str | None, arm: ArmDescription) -> str:
    """The model fitted: ``--model``, or physics where the arm has masses, geometry otherwise."""
    if model is None:
        return "physics" if arm.has_masses else "geometry"
    if model == "physics" and not arm.has_masses:
        raise BadInput(
            f"--model physics needs the arm's masses (mass_kg and com_mm per joint in {arm.source})"
        )
    return model


def check_holdout(holdout: float | None) -> None:
    """``--holdout``: a fraction of each training recording's rows, between 0 and 0.9."""
    if holdout is not None and not 0.0 < holdout < 0.9:
        raise BadInput(f"--holdout {holdout}: a fraction between 0 and 0.9")


def discovered_terms(
    training: list[TrainingRecording], arm: ArmDescription
) -> tuple[dict, list[AngleTerm]]:
    """``--effects discover``: the discovery on the training rows alone (held-out rows never
    shape the model), and its joint-angle effects as terms of the fit."""
    # imported when asked: discovery's modules add a second or two to every fit's start
    from calibench.scenarios.arm_cmm.discovery import discover_arm

    parts = [tr.rec.subset(tr.used) for tr in training]
    discovery, _ = discover_arm(parts if len(parts) > 1 else parts[0], arm=arm)
    return discovery, angle_terms_from_discovery(discovery, arm.n_joints, len(training))


def effects_used(effects: Path | str, terms: list[AngleTerm], discovery: dict | None) -> dict:
    """fit.json's ``effects_from``: where the effects came from and the terms they became."""
    said: dict = {
        "file": "discovery on the training rows" if discovery is not None else str(effects),
        "terms": [t.names[0].rsplit("_", 1)[0] for t in terms],
    }
    if discovery is not None:
        said["summary"] = discovery["summary"]
    return said


@dataclasses.dataclass(frozen=True)
class Unit:
    """A parameter's unit in fit.json and its factor from the estimator's (mm, rad, rad / N m)."""

    name: str
    factor: float


MM, URAD, URAD_PER_NM = Unit("mm", 1.0), Unit("urad", 1e6), Unit("urad_per_nm", 1e6)


def parameter_units(problem: PointProblem) -> dict[str, Unit]:
    """Each of the problem's parameters with its unit, by the block it belongs to: the chain's
    errors (angles or lengths, as :func:`~calibench.estimators.arm.kinematics.param_is_angle`
    says) and the tool, the compliances, the joint-angle terms' coefficients, the base frames
    (a turn and a shift each)."""
    chain_names = problem.names[: problem.nk]
    units = {n: URAD if a else MM for n, a in zip(chain_names, param_is_angle(chain_names))}
    compliances = problem.names[problem.nk : problem.nk + problem.n_phys]
    units.update({n: URAD_PER_NM for n in compliances})
    units.update({n: URAD for t in problem.terms for n in t.names})
    # each frame's six: rx, ry, rz (rad), then x, y, z (mm)
    units.update({n: URAD if k % 6 < 3 else MM for k, n in enumerate(problem.frame_names)})
    return units


def fit_summary(
    arm: ArmDescription,
    model: str,
    cal: ArmCalibration,
    chain: Chain,
    training: list[TrainingRecording],
    e_fit: np.ndarray,
    effects_from: dict | None,
) -> dict:
    """fit.json's head: the estimates with their std in their units (the base frames apart),
    what was dropped and why, each recording's base frame, the tool point, the fit's own
    figures and its model-error sigma. ``e_fit`` (n, 3): the fit's residuals, mm."""
    prob, s, ident = cal.problem, cal.state, cal.ident
    units = parameter_units(prob)
    result: dict = {
        "scenario": NAME,
        "arm": arm.name,
        "model": model,
        "samples": int(len(prob.y)),
        "parameters": [],
        "dropped": [],
        "converged": bool(ident.converged),
    }
    if effects_from is not None:
        result["effects_from"] = effects_from
    for name in (prob.names[k] for k in ident.basis.kept):
        if name.startswith("base_"):
            continue  # each recording's frame: under "bases"
        u = units[name]
        entry = {
            "name": name,
            "unit": u.name,
            "estimate": ident.estimate[name] * u.factor,
            "std": ident.std[name] * u.factor,
        }
        if name.startswith("cable_compliance") and chain.coupling is not None:
            # at the motor in the coupling's motor unit; seen at its joints whatever that unit
            m = int(name.removeprefix("cable_compliance"))
            norm2 = float(np.sum(np.asarray(chain.coupling, float)[:, m - 1] ** 2))
            entry["at_joints"] = {k: entry[k] * norm2 for k in ("estimate", "std")}
        result["parameters"].append(entry)
    dropped = {**ident.basis.dropped, **cal.compliance_dropped}
    result["dropped"] = [{"name": k, "why": v} for k, v in dropped.items()]
    bases = {
        tr.label: {
            "translation_mm": s.t[i].tolist(),
            "rotvec_rad": matrix_to_rotvec(s.R[i]).tolist(),
        }
        for i, tr in enumerate(training)
    }
    result["base"] = bases[training[0].label]
    result["bases"] = bases
    N = chain.n_joints
    tools = chain.tool_offsets() + s.delta[5 * N :].reshape(-1, 3)
    result["tool_mm"] = tools[0].tolist()
    if chain.n_tools > 1:  # a branched arm's every tool, its [[tool]] tables' order
        result["tools_mm"] = tools.tolist()
    fit_fig = error_statistics(e_fit)
    result["fit"] = {k: fit_fig[k] for k in ("mean_mm", "rms_mm", "max_mm")}
    result["sigma_model_mm"] = cal.sigma_model_mm
    extra = np.broadcast_to(np.asarray(prob.extra_var, float), (len(training),))
    result["sigma_model_mm_by_recording"] = {
        tr.label: float(np.sqrt(v)) for tr, v in zip(training, extra)
    }
    return result


def training_residuals(
    training: list[TrainingRecording], rows: Stacked, outliers: np.ndarray, cal: ArmCalibration
) -> list[ResidualPart]:
    """residuals.csv's training parts: each recording's fitted rows (the fit's own residuals)
    and, modelled apart, the rows the fit left out as outliers. ``outliers``: (n,) bool over
    the stacked rows."""
    prob, state = cal.problem, cal.state
    parts = []
    for i, tr in enumerate(training):
        mine = rows.rec_id == i
        parts.append(ResidualPart(tr.label, rows.rows[mine & ~outliers], "train", None))
        if outliers[mine].any():
            r = rows.rows[mine & outliers]
            modelled = prob.model(state, tr.rec.q_rad, frame=i, session=i, tool=tr.rec.tool)
            e = tr.rec.xyz_mm[r] - modelled[r]
            parts.append(ResidualPart(tr.label, r, "left_out", e))
    return parts


@dataclasses.dataclass
class FitOutputs:
    """What the scores add to the outputs, gathered as each recording is scored.

    result : fit.json's content (its ``holdout``, ``test``, ``in_sample``).
    residuals : residuals.csv's parts, in order.
    figures : fit.png's curves, {name: (k,) 3-D errors, mm}.
    flagged : {recording: its rows left out, with why}.
    scored, registered : {path: (k,) rows} scored, and those a new frame was fitted on.
    tested : {recording: (m, N) its readings, rad}: the postures the fit is tested on.
    """

    result: dict
    residuals: list[ResidualPart]
    figures: dict[str, np.ndarray]
    flagged: dict[str, list[dict]]
    scored: dict[Path, np.ndarray] = dataclasses.field(default_factory=dict)
    registered: dict[Path, np.ndarray] = dataclasses.field(default_factory=dict)
    tested: dict[str, np.ndarray] = dataclasses.field(default_factory=dict)

    def add(
        self,
        path: Path,
        label: str,
        score: Score,
        chose: np.ndarray | None,
        q_rad: np.ndarray | None = None,
    ) -> None:
        """Record ``score`` of the recording at ``path``: under its kind, or ``in_sample`` with
        why (its frame fitted on the rows it scores, or ``chose``, the rows that chose the
        model's structure, overlap them or cannot be known). ``q_rad``: a test recording's
        readings (n, N) rad, for the coverage warnings."""
        if score.in_sample_why:
            was = {"was": score.kind, "why": score.in_sample_why}
            self.result.setdefault("in_sample", {})[label] = {**score.figures, **was}
        else:
            record_score(self.result, score.kind, label, score.figures, score.scored_rows, chose)
        self.scored[path] = score.scored_rows
        if len(score.registered_rows):
            self.registered[path] = score.registered_rows
        self.residuals += score.residuals
        self.figures[score.curve] = score.error_mm
        if score.flagged is not None:
            self.flagged[label] = score.flagged
        if q_rad is not None:
            self.tested[label] = q_rad


def provenance(
    training: list[TrainingRecording],
    rows: Stacked,
    outliers: np.ndarray,
    tested: list[Path],
    out: FitOutputs,
    chosen_by: Callable,
) -> list[dict]:
    """fit.json's ``provenance``: per recording the rows that chose the model's structure, that
    fitted it (a training recording's rows in the fit; a new frame's registration rows) and that
    scored it."""
    return [
        entry(
            tr.path,
            chose=chose_or_none(chosen_by, tr.path, tr.used),
            fitted=rows.rows[(rows.rec_id == i) & ~outliers],
            scored=out.scored.get(tr.path, ()),
        )
        for i, tr in enumerate(training)
    ] + [
        entry(
            p,
            chose=chose_or_none(chosen_by, p, None),
            fitted=out.registered.get(p, ()),
            scored=out.scored.get(p, ()),
        )
        for p in tested
    ]


def coverage_said(
    chain: Chain,
    rows: Stacked,
    tested: dict[str, np.ndarray],
    prob: PointProblem,
    training: list[TrainingRecording],
) -> list[str]:
    """fit.json's coverage warnings: where the training postures leave out part of the
    workspace (:func:`~calibench.estimators.arm.workspace.coverage_warnings`), and stated std
    left unused because not every training recording states one."""
    said = coverage_warnings(chain, rows.q_rad, tested, [int(j) for j in prob.cj])
    stated = [tr.label for tr in training if tr.rec.xyz_std_mm is not None]
    if stated and len(stated) < len(training):
        # one weighting for all, or the recordings' weights would not compare
        said.append(
            f"{', '.join(stated)} state{'s' if len(stated) == 1 else ''} a std per value, "
            f"{', '.join(tr.label for tr in training if tr.label not in stated)} not: the stated "
            "std are not used, every row is weighted by the fitted scatter of its recording"
        )
    return said


def implausible(result: dict, arm: ArmDescription, tests: list[str], frame: str) -> list[str]:
    """What makes the fit no result, the first sentence first: a fit beyond
    :data:`PLAUSIBLE_RMS_MM` (a wrong description, columns in other units) or, the fit
    plausible, a same-frame test (``tests``: their names; ``frame``: the first training
    recording's) hundreds of times off it (its tracker stood elsewhere)."""
    rms_mm = result["fit"]["rms_mm"]
    if rms_mm > PLAUSIBLE_RMS_MM:
        return [
            f"the fit leaves {rms_mm:.3g} mm RMS, far beyond any arm's or instrument's error: is "
            f"the arm description right (--arm; this fit used {arm.name}) and are the columns "
            "in degrees and mm?"
        ]
    said = []
    for name in tests:
        # a test scored on rows whose effects were chosen on it is said in-sample, not a test
        scored = result.get("test", {}).get(name) or result.get("in_sample", {}).get(name)
        if scored is None:
            continue
        got = scored["rms_mm"]
        if got > PLAUSIBLE_RMS_MM and got > 100 * rms_mm:
            said.append(
                f"{name}: {got:.4g} mm RMS off the fitted arm in {frame}'s "
                "frame: is it from another setup? (--test-new-frame registers its own frame)"
            )
    return said


def write_residuals(path: Path, parts: list[ResidualPart], e_train: np.ndarray) -> None:
    """residuals.csv: every row the fit modelled, as measured minus modelled (mm) in its
    recording's frame: ``file, row`` (0-based, the recording's order), ``role`` (train: in the
    fit; left_out: a training row the fit left out; holdout; register: a new frame's
    registration rows; test; in_sample: scored rows a new frame was fitted on, the floor),
    ``ex_mm, ey_mm, ez_mm``. For analyses of what the model leaves
    out (periodic errors, drift along the row order). ``e_train`` (n, 3): the fit's residuals,
    the ``train`` parts' errors in the order the fit stacked them."""
    lines = ["file,row,role,ex_mm,ey_mm,ez_mm"]
    at = 0
    for part in parts:
        e = part.e_mm
        if e is None:  # the training rows, in the order the fit stacked them
            e, at = e_train[at : at + len(part.rows)], at + len(part.rows)
        lines += [
            f"{part.file},{r},{part.role},{x:.6f},{y:.6f},{z:.6f}"
            for r, (x, y, z) in zip(part.rows, e)
        ]
    write_text(path, "\n".join(lines) + "\n")
