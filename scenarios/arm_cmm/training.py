"""The training rows of ``fit arm-cmm``: the recordings read and screened without a model, split
into fitted and held-out rows, stacked, calibrated, and their disagreeing repeats settled by the
fitted model before the refit.

``discover arm-cmm`` starts from the same step (:func:`calibrate`, :func:`check_postures`), so
both commands import it from here and neither imports the other's module.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import numpy as np

from calibench.estimators.arm import calibration
from calibench.estimators.arm.calibration import ArmCalibration, DegenerateFit
from calibench.estimators.arm.kinematics import Chain
from calibench.estimators.arm.screening import screen
from calibench.estimators.arm.terms import AngleTerm, directions
from calibench.recordings import ArmRecording, load_arm_csv
from calibench.scenarios.progress import staged
from calibench.scenarios.report import BadInput
from calibench.scenes.arm_cmm import ArmDescription

SPLIT_SEED = 0  # holdout rows and new-frame registration rows: fixed, so runs compare
MAX_ROWS = 500_000  # the Jacobian (3 rows x ~50 columns a posture) stays under 1 GB


def calibrate(*args: Any, **kwargs: Any) -> ArmCalibration:
    """:func:`calibench.estimators.arm.calibration.calibrate` (the same arguments: q (n, N) rad,
    xyz (n, 3) mm, recording (n,), sigma (n, 3) mm or None), data it cannot determine said as
    bad input in one line (an arm whose links have no length, postures that never move the tool
    point, too few postures)."""
    with staged("calibrating"):  # the minutes of a fit on thousands of postures
        try:
            return calibration.calibrate(*args, **kwargs)
        except DegenerateFit as e:
            raise BadInput(str(e)) from None


def check_postures(q: np.ndarray, n_recordings: int) -> None:
    """Degenerate posture sets are bad input: too few distinct postures, or one repeated.

    Parameters
    ----------
    q : (n, N) the readings of every recording stacked, rad.
    n_recordings : how many recordings (each adds its own frame's six parameters).
    """
    distinct = len(np.unique(np.round(np.degrees(q), 2), axis=0))
    if distinct < 0.1 * len(q) and distinct < 50:
        raise BadInput(
            f"{len(q)} rows but only {distinct} distinct postures: repeats carry no new "
            "information for calibration"
        )
    if distinct < 10 + 6 * n_recordings:
        raise BadInput(f"{distinct} distinct postures: too few to calibrate the arm")


def recording_labels(paths: list[Path]) -> dict[Path, str]:
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


def load_recording(path: Path, arm: ArmDescription) -> ArmRecording:
    """An arm recording at ``path``, checked against the arm's joints and their ranges (and a
    branched arm's followers and tools)."""
    return load_arm_csv(
        path, arm.n_joints, MAX_ROWS, np.degrees(arm.range_rad), arm.follows, arm.n_tools
    )


@dataclasses.dataclass
class Screened:
    """What the model-free screening leaves of one recording.

    keep : (n,) bool, the rows kept (the stale readings out).
    flagged : the rows left out, each ``{"row", "why"}`` (fit.json's ``flagged``).
    pairs : (row a, row b, distance mm) of each repeat whose readings disagree, both rows still
        kept: a model settles which is the bad one (:func:`settle_pairs`).
    repeatability_mm : the median distance between repeated postures (None without repeats).
    """

    keep: np.ndarray
    flagged: list[dict]
    pairs: list[tuple[int, int, float]]
    repeatability_mm: float | None


def screened(rec: ArmRecording) -> Screened:
    """The rows of ``rec`` kept after the model-free screening, what was flagged, and the
    disagreeing pairs left for a model to settle."""
    s = screen(rec.q_rad, rec.xyz_mm, tool=rec.tool)
    keep = np.ones(len(rec), bool)
    flagged: list[dict] = []
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
    return Screened(keep, flagged, pairs, s.repeatability_mm)


def settle_pairs(
    keep: np.ndarray,
    flagged: list[dict],
    pairs: list[tuple[int, int, float]],
    model_xyz_mm: np.ndarray,
    meas_xyz_mm: np.ndarray,
    repeatability_mm: float | None,
) -> None:
    """Of each disagreeing pair, leave out the row farther from the model: cleared in ``keep``
    (n,) and said in ``flagged``, both changed in place. ``model_xyz_mm`` and ``meas_xyz_mm``:
    (n, 3) the modelled and measured points in the recording's frame."""
    for a, b, d in pairs:
        ea, eb = (np.linalg.norm(model_xyz_mm[i] - meas_xyz_mm[i]) for i in (a, b))
        bad, good = (a, b) if ea > eb else (b, a)
        keep[bad] = False
        flagged.append(
            {
                "row": bad,
                "why": f"the same posture as row {good}, measured {d:.2f} mm away from it "
                f"(repeatability {repeatability_mm:.3f} mm); this one is the farther from the "
                "model",
            }
        )


@dataclasses.dataclass
class TrainingRecording:
    """One training recording and what the fit makes of its rows.

    path, label : the file and its name in fit.json.
    rec : the recording as read.
    screening : the model-free screening; its ``keep`` (n,) bool becomes the rows the fit uses
        (the held-out rows out, the farther row of each disagreeing repeat out once settled) and
        its ``flagged`` grows with each row left out.
    held : (n,) bool, the rows held out to score the fit (``--holdout``), or None.
    """

    path: Path
    label: str
    rec: ArmRecording
    screening: Screened
    held: np.ndarray | None = None

    @property
    def used(self) -> np.ndarray:
        """(n,) bool: the rows the fit uses."""
        return self.screening.keep


def split_training(
    paths: list[Path], recs: list[ArmRecording], labels: dict[Path, str], holdout: float | None
) -> list[TrainingRecording]:
    """Screen each training recording and hold out a drawn ``holdout`` fraction of its rows (one
    generator of :data:`SPLIT_SEED` over the recordings in order); each needs 3 usable rows
    left for its base registration."""
    rng = np.random.default_rng(SPLIT_SEED)
    out = []
    for p, rec in zip(paths, recs):
        tr = TrainingRecording(p, labels[p], rec, screened(rec))
        if holdout:
            idx = rng.permutation(len(rec))
            held = np.zeros(len(rec), bool)
            held[idx[: int(round(holdout * len(rec)))]] = True
            if not (held & tr.used).any():
                raise BadInput(
                    f"--holdout {holdout:g} holds out no usable row of {p} ({len(rec)} rows)"
                )
            tr.held = held & tr.used
            tr.screening.keep &= ~held
        out.append(tr)
    for tr in out:
        if tr.used.sum() < 3:
            raise BadInput(
                f"{tr.path}: {tr.used.sum()} usable rows; a base registration needs at least 3"
            )
    return out


@dataclasses.dataclass
class Stacked:
    """The training rows the fit uses, every recording's stacked in order.

    q_rad : (n, N) the readings; xyz_mm : (n, 3) the measured points, each in its recording's
    frame; rec_id : (n,) which recording; sigma_mm : (n, 3) the stated std, or None (not every
    recording states one); rows : (n,) each row's index in its own recording; tool : (n,) each
    row's tool (0-based), or None where no recording has a ``tool`` column.
    """

    q_rad: np.ndarray
    xyz_mm: np.ndarray
    rec_id: np.ndarray
    sigma_mm: np.ndarray | None
    rows: np.ndarray
    tool: np.ndarray | None = None


def stacked(training: list[TrainingRecording]) -> Stacked:
    """The rows each recording's ``used`` keeps, stacked (:class:`Stacked`)."""
    recs = [tr.rec for tr in training]
    used = [tr.used for tr in training]
    stds = [r.xyz_std_mm for r in recs]
    # one weighting for all: the stated std only where every recording states one
    sigma = (
        np.vstack([s[k] for s, k in zip(stds, used) if s is not None])
        if all(s is not None for s in stds)
        else None
    )
    return Stacked(
        np.vstack([r.q_rad[k] for r, k in zip(recs, used)]),
        np.vstack([r.xyz_mm[k] for r, k in zip(recs, used)]),
        np.concatenate([np.full(k.sum(), i) for i, k in enumerate(used)]),
        sigma,
        np.concatenate([np.flatnonzero(k) for k in used]),
        None
        if all(r.tool is None for r in recs)
        else np.concatenate([np.zeros(len(r), int) if r.tool is None else r.tool for r in recs])[
            np.concatenate(used)
        ],
    )


def stacked_directions(
    training: list[TrainingRecording], chain: Chain, terms: list[AngleTerm]
) -> np.ndarray | None:
    """Each drive's direction of last motion (n, 2 N) at the rows :func:`stacked` keeps, taken
    over every row of its recording (a row held out or left out still moved the drives); None
    where no term needs it."""
    if not any(t.kind == "direction" for t in terms):
        return None
    coupling = None if chain.coupling is None else np.asarray(chain.coupling, float)
    return np.vstack([directions(tr.rec.q_rad, None, coupling)[tr.used] for tr in training])


def calibrate_and_settle(
    training: list[TrainingRecording],
    arm: ArmDescription,
    chain: Chain,
    model: str,
    terms: list[AngleTerm],
) -> tuple[ArmCalibration, Stacked]:
    """Calibrate on the training rows; settle each recording's disagreeing repeats with the
    fitted model (its frame and session) and, if there were any, refit without the farther rows.

    Returns
    -------
    The calibration, and the rows it was fitted on.
    """

    def fit(rows: Stacked) -> ArmCalibration:
        return calibrate(
            chain,
            rows.q_rad,
            rows.xyz_mm,
            rows.rec_id,
            rows.sigma_mm,
            model,
            arm.parallel_pairs(),
            angle_terms=terms,
            dirs=stacked_directions(training, chain, terms),
            tool=rows.tool,
        )

    rows = stacked(training)
    cal = fit(rows)
    if not any(tr.screening.pairs for tr in training):
        return cal, rows
    for i, tr in enumerate(training):
        if tr.screening.pairs:
            settle_pairs(
                tr.used,
                tr.screening.flagged,
                tr.screening.pairs,
                cal.problem.model(cal.state, tr.rec.q_rad, frame=i, session=i, tool=tr.rec.tool),
                tr.rec.xyz_mm,
                tr.screening.repeatability_mm,
            )
    rows = stacked(training)
    return fit(rows), rows


def flag_outliers(
    training: list[TrainingRecording], cal: ArmCalibration, rows: Stacked
) -> np.ndarray:
    """Say in each recording's ``flagged`` the training rows the calibration left out as
    outliers (beyond any Gaussian scatter of the fit's size).

    Returns
    -------
    (n,) bool over the stacked rows: the outliers.
    """
    for i_row in cal.outliers:
        tr = training[int(rows.rec_id[i_row])]
        tr.screening.flagged.append(
            {
                "row": int(rows.rows[i_row]),
                "why": "its residual is beyond any Gaussian scatter of the fit's size "
                "(p < 1e-6): left out of the fit",
            }
        )
    out = np.zeros(len(rows.q_rad), bool)
    out[cal.outliers] = True
    return out
