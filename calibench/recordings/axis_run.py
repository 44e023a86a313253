"""Reading a bidirectional positioning run of one axis (ISO 230-2) and its checks."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from calibench.recordings.csv_io import RecordingError, read_columns
from calibench.recordings.records import AxisRun

# readings of one run: ISO 230-2 asks for 5 runs each way, so a million is 100,000 targets
MAX_ROWS = 1_000_000
# a file with both deviation_um and actual_mm: how far they may differ (um), their rounding's
# room (actual_mm to 3 decimals is up to 0.5 um off, deviation_um's own rounding besides), not
# a second reading's
AGREE_UM = 1.0
# mm: the farthest target of an axis. No machine's axis is a kilometre long, and float64 keeps
# a deviation's digits only near the target's scale (at 1e12 mm, actual_mm - target_mm is
# 0.1 um coarse; at a kilometre, 1e-7 um); a target beyond is a wrong unit or a corrupt value
MAX_TARGET_MM = 1e6


def load_axis_run(path: str | Path) -> AxisRun:
    """Read a bidirectional run (docs/formats.md, "iso230").

    Parameters
    ----------
    path : str or Path
        The CSV: target_mm, run, direction and either deviation_um or actual_mm (both: they
        must agree within AGREE_UM).

    Returns
    -------
    AxisRun
        (k,) arrays, one per reading; the deviation in um either way.

    Raises
    ------
    RecordingError
        A missing column, a direction other than +1 / -1, a target beyond
        :data:`MAX_TARGET_MM`, a deviation over a metre, over :data:`MAX_ROWS` readings.
    """
    path = Path(path)
    cols, line = read_columns(
        path, ("target_mm", "run", "direction"), ("deviation_um", "actual_mm"), MAX_ROWS
    )
    far = np.abs(cols["target_mm"]) > MAX_TARGET_MM
    if far.any():
        bad = int(np.argmax(far))
        raise RecordingError(
            f"{path} line {line[bad]}: target_mm is {cols['target_mm'][bad]:.3g}, over a "
            "kilometre: no machine's axis (a wrong unit or a corrupt value), and float64 would "
            "keep no micrometre of its deviation"
        )
    if "deviation_um" in cols:
        dev = cols["deviation_um"]
        if "actual_mm" in cols:  # both given: they must say the same, else which one is meant?
            off = np.abs(dev - (cols["actual_mm"] - cols["target_mm"]) * 1000.0)
            bad = int(np.argmax(off))
            if off[bad] > AGREE_UM:
                raise RecordingError(
                    f"{path} line {line[bad]}: deviation_um and actual_mm - target_mm differ by "
                    f"{off[bad]:.3g} um; give one of the two columns"
                )
    elif "actual_mm" in cols:
        dev = (cols["actual_mm"] - cols["target_mm"]) * 1000.0
    else:
        raise RecordingError(f"{path}: missing column deviation_um (or actual_mm)")
    d = cols["direction"]
    if not np.all(np.isin(d, (-1.0, 1.0))):
        bad = int(np.argmax(~np.isin(d, (-1.0, 1.0))))
        raise RecordingError(
            f"{path} line {line[bad]}: direction is {d[bad]:g}; +1 (approached from below) or -1"
        )
    if np.abs(dev).max() > 1e6:
        raise RecordingError(
            f"{path}: a deviation of {np.abs(dev).max():.3g} um (over a metre): wrong unit or a "
            "corrupt value"
        )
    # a spreadsheet's export writes 100 as 100.000000001 on some rows: one target to the nanometre
    # (ISO 230-2's targets are set to the micrometre at the finest)
    return AxisRun(np.round(cols["target_mm"], 6), cols["run"], d.astype(int), dev)
