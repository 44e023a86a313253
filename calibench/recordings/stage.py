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
    """Read a stage recording (CONTRACT, "Stage recordings").

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
        direction other than -1, 0, +1.
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
    for name in ("dir_x", "dir_y"):
        if name in cols and not np.isin(cols[name], (-1.0, 0.0, 1.0)).all():
            i = int(np.argmax(~np.isin(cols[name], (-1.0, 0.0, 1.0))))
            raise RecordingError(
                f"{path} line {line[i]}: {name} is {cols[name][i]:g}; a direction is -1, 0 or +1"
            )
    return StageRecording(**cols)
