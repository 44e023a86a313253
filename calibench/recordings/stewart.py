"""Reading a Stewart platform's recording and its checks."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from calibench.recordings.csv_io import RecordingError, read_columns
from calibench.recordings.records import STEWART_POSE, StewartRecording


def load_stewart_csv(path: str | Path, max_rows: int | None = None) -> StewartRecording:
    """Read a Stewart recording (docs/formats.md, "Recordings").

    Parameters
    ----------
    path : str or Path
        The CSV: l1_mm..l6_mm and the tracker's pose x_mm, y_mm, z_mm, rx_deg, ry_deg, rz_deg
        (XYZ intrinsic Euler angles); optional t_s, temp_c, dir_1..dir_6 (all six or none),
        load_n.
    max_rows : int or None
        Refuse longer recordings before converting them.

    Returns
    -------
    StewartRecording
        readings (n, 6), the pose as R (n, 3, 3) and t_mm (n, 3).

    Raises
    ------
    RecordingError
        Any defect of the file, some dir_ columns without the others, a direction other than
        -1, 0, +1, an angle beyond 360 deg, a coordinate beyond a kilometre.
    """
    from scipy.spatial.transform import Rotation

    legs = tuple(f"l{i}_mm" for i in range(1, 7))
    dirs = tuple(f"dir_{i}" for i in range(1, 7))
    cols, line = read_columns(
        path, legs + STEWART_POSE, ("t_s", "temp_c", "load_n") + dirs, max_rows
    )
    present = [c for c in dirs if c in cols]
    if present and len(present) < 6:
        raise RecordingError(
            f"{path}: {', '.join(present)} without the others: give all of dir_1..dir_6 or none"
        )
    direction = np.stack([cols[c] for c in dirs], axis=1) if present else None
    if direction is not None and not np.isin(direction, (-1.0, 0.0, 1.0)).all():
        i = int(np.argmax(~np.isin(direction, (-1.0, 0.0, 1.0)).all(axis=1)))
        raise RecordingError(f"{path} line {line[i]}: a dir_ column is not -1, 0 or +1")
    ang = np.stack([cols[c] for c in ("rx_deg", "ry_deg", "rz_deg")], axis=1)
    _in_range(path, line, ang, 360, "an angle of {:.3g} deg in rx/ry/rz", "not degrees")
    t = np.stack([cols[c] for c in ("x_mm", "y_mm", "z_mm")], axis=1)
    _in_range(path, line, t, 1e6, "a coordinate of {:.3g} mm (over a kilometre)", "wrong unit")
    return StewartRecording(
        np.stack([cols[c] for c in legs], axis=1),
        Rotation.from_euler("XYZ", ang, degrees=True).as_matrix(),
        t,
        cols.get("t_s"),
        cols.get("temp_c"),
        direction,
        cols.get("load_n"),
    )


def _in_range(path, line: np.ndarray, values: np.ndarray, limit: float, what: str, unit: str):
    """Refuse values (n, k) beyond ``limit``: a few rows are corrupt rows, named by their line;
    most rows beyond it are a wrong unit."""
    bad = np.any(np.abs(values) > limit, axis=1)
    if not bad.any():
        return
    worst = float(np.abs(values[bad]).max())
    if bad.mean() > 0.5:
        raise RecordingError(f"{path}: {what.format(worst)} in most rows: {unit}")
    rows = ", ".join(str(int(x)) for x in line[bad][:5]) + (" ..." if bad.sum() > 5 else "")
    raise RecordingError(
        f"{path} line{'s' if bad.sum() > 1 else ''} {rows}: {what.format(worst)}, where the other "
        "rows are in range: a corrupt row"
    )
