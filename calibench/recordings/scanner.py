"""Reading a probe-scanner recording and its checks."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from calibench.recordings.csv_io import RecordingError, read_columns
from calibench.recordings.records import ScannerRecording

MAX_RHO_MM = 1000.0  # a spectacle frame's scanner reads within a few cm of its axis


def load_scanner_csv(path: str | Path, max_rows: int | None = None) -> ScannerRecording:
    """Read a probe-scanner recording (docs/formats.md, "Recordings").

    Parameters
    ----------
    path : str or Path
        The CSV: turn, theta_deg, rho_mm; optional t_s, temp_c.
    max_rows : int or None
        Refuse longer recordings before converting them.

    Returns
    -------
    ScannerRecording
        (n,) arrays, the angle in rad.

    Raises
    ------
    RecordingError
        Any defect of the file, a turn that is not an integer, a reading that is not positive or
        beyond a metre, an angle beyond 100 turns.
    """
    cols, line = read_columns(path, ("turn", "theta_deg", "rho_mm"), ("t_s", "temp_c"), max_rows)
    turn = cols["turn"]
    if np.any(turn != np.round(turn)):
        i = int(np.argmax(turn != np.round(turn)))
        raise RecordingError(f"{path} line {line[i]}: turn is {turn[i]:g}; a turn is an integer")
    if np.any(cols["rho_mm"] <= 0):
        i = int(np.argmax(cols["rho_mm"] <= 0))
        raise RecordingError(
            f"{path} line {line[i]}: rho_mm is {cols['rho_mm'][i]:g}; a probe reading is positive"
        )
    if np.any(cols["rho_mm"] > MAX_RHO_MM):
        i = int(np.argmax(cols["rho_mm"] > MAX_RHO_MM))
        raise RecordingError(
            f"{path} line {line[i]}: rho_mm is {cols['rho_mm'][i]:.3g}: "
            f"over {MAX_RHO_MM:g} mm from the table's axis, a wrong unit (um?) or a corrupt value"
        )
    if np.abs(cols["theta_deg"]).max() > 36000:
        raise RecordingError(
            f"{path}: a table angle of {np.abs(cols['theta_deg']).max():.3g} deg: not an angle "
            "in degrees"
        )
    return ScannerRecording(
        turn.astype(int),
        np.deg2rad(cols["theta_deg"]),
        cols["rho_mm"],
        cols.get("t_s"),
        cols.get("temp_c"),
    )
