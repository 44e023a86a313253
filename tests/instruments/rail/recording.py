"""The rail's recording format: what its interferometer recorded, one row per reading.

CSV, one header row (docs/formats.md's rules: required columns present and finite):

| column | meaning |
|---|---|
| ``x_cmd_mm`` | the commanded position |
| ``x_meas_mm`` | the carriage's position read by the laser interferometer |
| ``dir_x`` | +1 / -1: the direction of the reading's approach |
| ``run`` | integer pass id |

``calibench run rail`` writes it (``DIR/recording.csv``), ``calibench discover rail`` reads it.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from calibench.recordings.csv_io import RecordingError, read_columns, write_csv

COLUMNS = ("x_cmd_mm", "x_meas_mm", "dir_x", "run")


@dataclasses.dataclass(frozen=True)
class RailRecording:
    """A rail recording: (n,) arrays, one per reading, in time order (mm; dir_x +1 / -1; run an
    integer pass id)."""

    x_cmd_mm: np.ndarray
    x_meas_mm: np.ndarray
    dir_x: np.ndarray
    run: np.ndarray

    def __len__(self) -> int:
        return len(self.x_cmd_mm)

    def to_csv(self, path: str | Path) -> None:
        """Write the recording in its format."""
        write_csv(path, list(COLUMNS), [getattr(self, c) for c in COLUMNS])


def load_rail_csv(path: str | Path, max_rows: int | None = None) -> RailRecording:
    """Read a rail recording.

    Parameters
    ----------
    path : the CSV file.
    max_rows : refuse a file with more data rows than this.

    Returns
    -------
    RailRecording

    Raises
    ------
    RecordingError
        (a BadInput) One line naming the file and the defect: a missing column, a cell that is
        not a finite number, a direction other than +1 / -1, a pass id that is not whole.
    """
    cols, line = read_columns(path, COLUMNS, (), max_rows)
    d = cols["dir_x"]
    bad = ~np.isin(d, (-1.0, 1.0))
    if bad.any():
        i = int(np.argmax(bad))
        raise RecordingError(
            f"{path} line {line[i]}: dir_x is {d[i]:g}; +1 (approached forward) or -1"
        )
    return RailRecording(*(cols[c] for c in COLUMNS))
