"""Reading a stage recording (belt-stage, vision-stage) and its checks."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from calibench.recordings.csv_io import RecordingError, read_columns
from calibench.recordings.records import StageRecording

MAX_STAGE_MM = (
    5e4  # 50 m, beyond the largest gantry: a coordinate there is a wrong unit or a corrupt value
)


def load_stage_csv(path: str | Path, max_rows: int | None = None) -> StageRecording:
    """Read a stage recording (docs/formats.md, "Stage recordings").

    Parameters
    ----------
    path : str or Path
        The CSV: x_cmd_mm, y_cmd_mm, x_meas_mm, y_meas_mm; optional t_s, dir_x, dir_y, temp_c,
        run.
    max_rows : int or None
        Refuse longer recordings before converting them.

    Returns
    -------
    StageRecording
        (n,) arrays, the absent optional columns None.

    Raises
    ------
    RecordingError
        One clear message for any defect: a missing column, a value that is not a number or not
        finite, a coordinate beyond 50 m or every one within 2 mm (micrometres, metres), a
        measured axis that does not follow its commanded one, a direction other than -1, 0, +1,
        a run column that makes most rows a pass of their own.
    """
    cols, line = read_columns(path, StageRecording.REQUIRED, StageRecording.OPTIONAL, max_rows)
    for name in StageRecording.REQUIRED:
        big = np.abs(cols[name]) > MAX_STAGE_MM
        if big.any():
            raise RecordingError(
                f"{path} line {line[int(np.argmax(big))]}: {name} is {cols[name][big][0]:.3g} mm "
                f"(over {MAX_STAGE_MM / 1000:g} m): a wrong unit (um?) or a corrupt value"
            )
    # the stage moved between stations, yet every coordinate stays within 2: the unit, not the stage
    xy = np.stack([cols[c] for c in StageRecording.REQUIRED], axis=1)
    if len(xy) >= 10 and np.ptp(xy[:, :2], axis=0).max() > 0 and np.abs(xy).max() < 2.0:
        raise RecordingError(
            f"{path}: every position lies within +-{np.abs(xy).max():.3g}: "
            "metres? the format wants millimetres (x_cmd_mm, ...)"
        )
    _measured_follow_commanded(path, cols)
    _passes_hold_rows(path, cols)
    for name in ("dir_x", "dir_y"):
        if name in cols and not np.isin(cols[name], (-1.0, 0.0, 1.0)).all():
            i = int(np.argmax(~np.isin(cols[name], (-1.0, 0.0, 1.0))))
            raise RecordingError(
                f"{path} line {line[i]}: {name} is {cols[name][i]:g}; a direction is -1, 0 or +1"
            )
    return StageRecording(**cols)


# A stage's scale error is parts per million to a percent: a measured axis that moves less than
# half or more than twice what was commanded along it is not measuring that axis.
SCALE_LIMITS = (0.5, 2.0)


def _measured_follow_commanded(path, cols: dict) -> None:
    """RecordingError when a measured column does not follow its commanded one (its slope against
    it, least squares, outside :data:`SCALE_LIMITS`): a frozen reading, the x and y columns
    swapped, another unit or another frame. An axis commanded over less than 1 mm is not judged:
    its slope is the noise's."""
    for axis in ("x", "y"):
        cmd, meas = cols[f"{axis}_cmd_mm"], cols[f"{axis}_meas_mm"]
        if len(cmd) < 3 or np.ptp(cmd) < 1.0:
            continue
        c = cmd - cmd.mean()
        slope = float(c @ (meas - meas.mean()) / (c @ c))
        if not SCALE_LIMITS[0] < slope < SCALE_LIMITS[1]:
            raise RecordingError(
                f"{path}: {axis}_meas_mm moves {slope:.3g} mm per mm of {axis}_cmd_mm: the "
                "measured positions do not follow the commanded ones (a frozen reading, x and y "
                "swapped, another unit or frame?)"
            )


def _passes_hold_rows(path, cols: dict) -> None:
    """RecordingError when the ``run`` column makes most rows a pass of their own (more passes
    than half the rows: a row index exported as the pass id). Refused rather than read as no
    passes: the file says something of its structure that is not so, and ``discover`` held out
    "a pass" that was one row, calling an effect confirmed by leaving one pass out."""
    run = cols.get("run")
    if run is None or len(run) < 4:
        return
    passes = len(np.unique(run))
    if 2 * passes > len(run):
        raise RecordingError(
            f"{path}: column run names {passes} passes for {len(run)} rows, most of them a row "
            "of its own (a row index?); a pass is one traverse over several stations: give its "
            "id, or drop the column if the recording has no passes"
        )


def repeated_pass(rec: StageRecording) -> str | None:
    """How a pass of ``rec`` repeats another row for row, every value the same (a file appended to
    itself, or a read-out coarser than the stage's repeatability), or None. ``discover`` refuses
    it: held out, such a pass scores a model on its own rows, and its repeats carry no scatter to
    judge an effect by; a fit of the error map takes it as it is."""
    names = [c for c in StageRecording.REQUIRED + StageRecording.OPTIONAL if c != "run"]
    rows = np.stack([getattr(rec, c) for c in names if getattr(rec, c) is not None], axis=1)
    if rec.run is not None:
        ids = np.unique(rec.run)
        passes = [rows[rec.run == r] for r in ids]
    elif len(rows) % 2 == 0 and len(rows) >= 4:
        ids = None
        passes = [rows[: len(rows) // 2], rows[len(rows) // 2 :]]  # the file twice, one after
    else:
        return None
    seen: dict[bytes, int] = {}
    for k, block in enumerate(passes):
        if len(block) < 2 or (block == block[0]).all():
            continue  # one station, repeated: a degenerate recording, which the fits say so
        key = block.tobytes()
        if key in seen:
            if ids is None:
                return "its second half repeats its first"
            return f"pass {int(ids[k]):d} repeats pass {int(ids[seen[key]]):d}"
        seen[key] = k
    return None
