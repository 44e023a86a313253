"""How well a fitted arm carries to rows it never saw: ``fit arm-cmm``'s held-out rows of the
training recordings, ``--test`` recordings in the first training recording's frame, and
``--test-new-frame`` recordings registered on a share of their rows and scored on the rest.

Each score says what its rows are; a score on rows a frame was fitted on (the floor of
``register_on_scored``) is said as in-sample.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from calibench.estimators.arm.calibration import DegenerateFit, error_statistics, register_frame
from calibench.estimators.arm.point import PointProblem, PointState
from calibench.estimators.arm.session import register_session, session_terms
from calibench.estimators.rotations import rigid_transform
from calibench.recordings import ArmRecording
from calibench.scenarios.arm_cmm.training import (
    SPLIT_SEED,
    TrainingRecording,
    screened,
    settle_pairs,
)
from calibench.scenarios.report import BadInput

REGISTER_FRACTION = 0.2
HOLDOUT_KIND = "random rows of a training session (interpolation within the sessions fitted)"


@dataclasses.dataclass
class ResidualPart:
    """Rows of one recording in residuals.csv.

    file : the recording's name; rows : (k,) its rows; role : what they were to the fit (train,
    left_out, holdout, register, test, in_sample); e_mm : (k, 3) measured minus modelled, mm, in
    the recording's frame, or None for the training rows (the fit's own residuals, in the order
    it stacked them).
    """

    file: str
    rows: np.ndarray
    role: str
    e_mm: np.ndarray | None


@dataclasses.dataclass
class Score:
    """One recording scored by the fitted arm.

    kind : where fit.json records it, ``"holdout"`` or ``"test"``.
    figures : :func:`~calibench.estimators.arm.calibration.error_statistics` of the scored rows
        and what they are (``frame``; a holdout's ``fraction`` and ``kind``).
    scored_rows : (k,) the rows scored; registered_rows : (m,) those its frame (and its
        session's own terms) were fitted on, empty in the training frame.
    residuals : its parts of residuals.csv.
    curve : fit.png's name for the scored rows; error_mm : (k,) their 3-D errors.
    flagged : a test recording's rows left out, with why (None for held-out rows: their
        recording's are the training's).
    in_sample_why : why the score is in-sample (its frame was fitted on the rows it scores), or
        None.
    """

    kind: str
    figures: dict
    scored_rows: np.ndarray
    registered_rows: np.ndarray
    residuals: list[ResidualPart]
    curve: str
    error_mm: np.ndarray
    flagged: list[dict] | None = None
    in_sample_why: str | None = None


def per_tool(problem: PointProblem, e_mm: np.ndarray, tool: np.ndarray | None) -> dict:
    """A branched arm's figures tool by tool: ``{"tools": {"1": figures, ...}}`` of the errors
    ``e_mm`` (k, 3) of rows measuring ``tool`` (k,) (0-based; None: the first), each tool that
    has rows; empty for an arm with one tool."""
    if problem.chain.n_tools == 1:
        return {}
    t = np.zeros(len(e_mm), int) if tool is None else np.asarray(tool, int)
    return {
        "tools": {
            str(k + 1): error_statistics(e_mm[t == k])
            for k in range(problem.chain.n_tools)
            if np.any(t == k)
        }
    }


def enough_to_judge(path: Path, keep: np.ndarray) -> None:
    """A test recording needs rows left to judge the fit on once its stale readings are out."""
    if keep.sum() < 3:
        raise BadInput(
            f"{path}: {keep.sum()} usable rows of {len(keep)} once the stale readings (a "
            "measurement repeated while the arm moved) are left out: too few to judge the fit on"
        )


def score_holdout(
    problem: PointProblem, state: PointState, tr: TrainingRecording, i: int, fraction: float
) -> Score | None:
    """The held-out rows of training recording ``tr`` (the ``i``-th: its own frame and session)
    scored by the fit; None when none is left to score. A row named bad (the farther of a
    disagreeing repeat, an outlier) is not scored, as in a test recording."""
    if tr.held is None:  # no --holdout
        return None
    m = tr.held.copy()
    m[[f["row"] for f in tr.screening.flagged]] = False
    if m.sum() == 0:
        return None
    rec = tr.rec
    # modelled over the whole recording: a drive's direction of last motion is its rows' order
    e = problem.model(state, rec.q_rad, frame=i, session=i, tool=rec.tool)[m] - rec.xyz_mm[m]
    rows = np.flatnonzero(m)
    tools = per_tool(problem, e, None if rec.tool is None else rec.tool[m])
    return Score(
        "holdout",
        {**error_statistics(e), "fraction": fraction, "kind": HOLDOUT_KIND, **tools},
        rows,
        np.empty(0, np.int64),
        [ResidualPart(tr.label, rows, "holdout", -e)],
        f"{tr.label} (held out)",
        np.linalg.norm(e, axis=1),
    )


def score_same_frame(
    problem: PointProblem,
    state: PointState,
    path: Path,
    label: str,
    rec: ArmRecording,
    frame_label: str,
) -> Score:
    """A ``--test`` recording scored in the first training recording's frame (``frame_label``:
    that recording's name), its disagreeing repeats settled by the fitted model first."""
    s = screened(rec)
    enough_to_judge(path, s.keep)
    model_xyz = problem.model(state, rec.q_rad, frame=0, tool=rec.tool)
    settle_pairs(s.keep, s.flagged, s.pairs, model_xyz, rec.xyz_mm, s.repeatability_mm)
    e = model_xyz[s.keep] - rec.xyz_mm[s.keep]
    rows = np.flatnonzero(s.keep)
    tools = per_tool(problem, e, None if rec.tool is None else rec.tool[s.keep])
    return Score(
        "test",
        {**error_statistics(e), "frame": f"{frame_label}'s", **tools},
        rows,
        np.empty(0, np.int64),
        [ResidualPart(label, rows, "test", -e)],
        f"{label} (test)",
        np.linalg.norm(e, axis=1),
        flagged=s.flagged,
    )


@dataclasses.dataclass
class NewFrame:
    """A recording's frame (and its session's own terms) registered on some of its rows.

    model_xyz_mm : (n, 3) the modelled points of every row in the recording's frame.
    register_rows : (k,) the drawn rows a frame is registered on; judge_rows : (m,) the others.
    fitted_on : (j,) the rows the final frame was fitted on (``register_rows``, or the scored
        ``judge_rows`` for the floor).
    own_urad : the session's own terms' coefficients, urad (empty without such terms).
    """

    model_xyz_mm: np.ndarray
    register_rows: np.ndarray
    judge_rows: np.ndarray
    fitted_on: np.ndarray
    own_urad: dict[str, float]


def register_new_frame(
    problem: PointProblem,
    state: PointState,
    path: Path,
    rec: ArmRecording,
    usable: np.ndarray,
    register_on_scored: bool,
) -> NewFrame:
    """Register the frame of a recording from another setup on a drawn
    :data:`REGISTER_FRACTION` of its ``usable`` (n,) rows (seed :data:`SPLIT_SEED`); what belongs
    to a session (a harmonic's phase set at power-up) is fitted beside its frame on those rows,
    never on the rows that score it. ``register_on_scored``: the floor, frame and own terms
    fitted by least squares on the scored rows themselves, so no registration leaves them a lower
    RMS."""
    base_pts = problem.base_points(state, rec.q_rad, tool=rec.tool)
    try:
        frame = register_frame(base_pts, rec.xyz_mm, usable, REGISTER_FRACTION, SPLIT_SEED)
    except DegenerateFit as e:
        raise BadInput(f"{path}: {e}") from None
    model_xyz = base_pts @ frame.R.T + frame.t
    on = frame.judge_rows if register_on_scored else frame.register_rows
    own: dict[str, float] = {}
    if session_terms(problem.terms):
        fitted, model_xyz = register_session(
            problem, state, rec.q_rad, rec.xyz_mm, on, tool=rec.tool
        )
        own = {n: float(v) * 1e6 for n, v in zip(fitted.names, fitted.coef)}
    elif register_on_scored:
        R, t = rigid_transform(base_pts[on], rec.xyz_mm[on])
        model_xyz = base_pts @ R.T + t
    return NewFrame(model_xyz, frame.register_rows, frame.judge_rows, on, own)


def score_new_frame(
    problem: PointProblem,
    state: PointState,
    path: Path,
    label: str,
    rec: ArmRecording,
    register_on_scored: bool,
) -> Score:
    """A ``--test-new-frame`` recording: its frame registered (:func:`register_new_frame`), its
    disagreeing repeats among the scored rows settled, the other rows scored."""
    s = screened(rec)
    enough_to_judge(path, s.keep)
    nf = register_new_frame(problem, state, path, rec, s.keep, register_on_scored)
    ev = np.zeros(len(rec), bool)
    ev[nf.judge_rows] = True
    both_scored = [pr for pr in s.pairs if ev[pr[0]] and ev[pr[1]]]
    settle_pairs(ev, s.flagged, both_scored, nf.model_xyz_mm, rec.xyz_mm, s.repeatability_mm)
    e = nf.model_xyz_mm[ev] - rec.xyz_mm[ev]
    reg = nf.register_rows
    parts = []
    if not register_on_scored:
        parts.append(ResidualPart(label, reg, "register", rec.xyz_mm[reg] - nf.model_xyz_mm[reg]))
    role = "in_sample" if register_on_scored else "test"
    parts.append(ResidualPart(label, np.flatnonzero(ev), role, -e))
    figs = {
        **error_statistics(e),
        **per_tool(problem, e, None if rec.tool is None else rec.tool[ev]),
        "frame": f"registered on {len(reg)} rows ({100 * REGISTER_FRACTION:.0f} %, "
        f"seed {SPLIT_SEED}), figures on the other {ev.sum()}",
    }
    if register_on_scored:
        figs["frame"] = (
            f"registered on the {len(nf.fitted_on)} rows it scores (in-sample: the floor)"
        )
    if nf.own_urad:
        figs["session_terms_urad"] = nf.own_urad
        figs["frame"] += (
            f"; the session's own terms ({len(nf.own_urad)} coefficients) fitted on those rows too"
        )
    floor = "its frame and own terms were fitted on these rows: a floor, not a result"
    return Score(
        "test",
        figs,
        np.flatnonzero(ev),
        nf.fitted_on,
        parts,
        f"{label} (new frame: scored rows)",
        np.linalg.norm(e, axis=1),
        flagged=s.flagged,
        in_sample_why=floor if register_on_scored else None,
    )
