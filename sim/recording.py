"""Recordings: what an instrument records, the one interface between world and algorithms.

Simulated and real recordings load into the same small dataclasses of numpy arrays, with units
in the field names. Truth never goes in here.
"""

from __future__ import annotations

import csv
import dataclasses
from pathlib import Path

import numpy as np


class RecordingError(ValueError):
    """A recording that cannot be used as it is (missing column, NaN, unreadable file)."""


@dataclasses.dataclass
class CameraViews:
    """Views of a chessboard by one camera.

    images : list of (height, width, 3) uint8, or None (analytic fidelity: no pixels).
    corners_px : (n_views, n_corners, 2) the detector's output, NaN where a view was not
        detected; filled by the detector for images, by the sensor model otherwise.
    names : one label per view (file name or station).
    """

    image_size: tuple[int, int]
    names: list[str]
    images: list[np.ndarray] | None = None
    corners_px: np.ndarray | None = None


@dataclasses.dataclass
class StageRecording:
    """Stations of a two-axis stage: commanded and measured positions (mm), CONTRACT format.

    Optional columns are None when absent.
    """

    x_cmd_mm: np.ndarray
    y_cmd_mm: np.ndarray
    x_meas_mm: np.ndarray
    y_meas_mm: np.ndarray
    t_s: np.ndarray | None = None
    dir_x: np.ndarray | None = None
    dir_y: np.ndarray | None = None
    temp_c: np.ndarray | None = None
    run: np.ndarray | None = None

    REQUIRED = ("x_cmd_mm", "y_cmd_mm", "x_meas_mm", "y_meas_mm")
    OPTIONAL = ("t_s", "dir_x", "dir_y", "temp_c", "run")

    def __len__(self) -> int:
        return len(self.x_cmd_mm)

    @property
    def x_err_mm(self) -> np.ndarray:
        return self.x_meas_mm - self.x_cmd_mm

    @property
    def y_err_mm(self) -> np.ndarray:
        return self.y_meas_mm - self.y_cmd_mm

    def to_csv(self, path: str | Path) -> None:
        cols = [c for c in self.REQUIRED + self.OPTIONAL if getattr(self, c) is not None]
        data = np.column_stack([getattr(self, c) for c in cols])
        with open(path, "w", newline="") as f:
            w = csv.writer(f)
            w.writerow(cols)
            w.writerows([[f"{v:.9g}" for v in row] for row in data])


def _read_columns(path: str | Path, required: tuple, optional: tuple) -> dict[str, np.ndarray]:
    """Numeric columns of a CSV by name; one clear RecordingError for any defect."""
    path = Path(path)
    try:
        with open(path, newline="") as f:
            rows = list(csv.reader(f))
    except OSError as e:
        raise RecordingError(f"cannot read {path}: {e.strerror}") from None
    except UnicodeDecodeError:
        raise RecordingError(f"{path} is not a text CSV file") from None
    if not rows or not rows[0]:
        raise RecordingError(f"{path} is empty")
    header = [h.strip() for h in rows[0]]
    missing = [c for c in required if c not in header]
    if missing:
        raise RecordingError(f"{path}: missing column(s) {', '.join(missing)}")
    body = [r for r in rows[1:] if any(cell.strip() for cell in r)]
    if not body:
        raise RecordingError(f"{path}: no data rows")
    fields = {}
    for name in required + optional:
        if name not in header:
            continue
        j = header.index(name)
        values = np.empty(len(body))
        for i, r in enumerate(body):
            try:
                values[i] = float(r[j])
            except (IndexError, ValueError):
                cell = r[j] if j < len(r) else ""
                raise RecordingError(f"{path} line {i + 2}: column {name} is {cell!r}, not a number") from None
        bad = ~np.isfinite(values)
        if bad.any():
            raise RecordingError(f"{path} line {int(np.argmax(bad)) + 2}: column {name} is not finite")
        fields[name] = values
    return fields


def load_stage_csv(path: str | Path) -> StageRecording:
    """Read a stage recording; one clear RecordingError for any defect."""
    return StageRecording(**_read_columns(path, StageRecording.REQUIRED, StageRecording.OPTIONAL))


@dataclasses.dataclass
class ArmRecording:
    """Encoder readings (n, 6) rad and the reference's probe centre (n, 3) mm; t_s, temp_c."""

    q_rad: np.ndarray
    xyz_mm: np.ndarray
    t_s: np.ndarray | None = None
    temp_c: np.ndarray | None = None

    def to_csv(self, path) -> None:
        cols = [f"q{j}_deg" for j in range(1, 7)] + ["x_mm", "y_mm", "z_mm"]
        data = [np.rad2deg(self.q_rad), self.xyz_mm]
        if self.t_s is not None:
            cols.append("t_s")
            data.append(self.t_s[:, None])
        if self.temp_c is not None:
            cols.append("temp_c")
            data.append(self.temp_c[:, None])
        np.savetxt(path, np.hstack(data), delimiter=",", header=",".join(cols), comments="", fmt="%.9g")


ARM_REQUIRED = tuple(f"q{j}_deg" for j in range(1, 7)) + ("x_mm", "y_mm", "z_mm")


def load_arm_csv(path: str | Path) -> ArmRecording:
    """Read an arm recording (CONTRACT: q1_deg..q6_deg, x_mm, y_mm, z_mm; t_s, temp_c optional)."""
    cols = _read_columns(path, ARM_REQUIRED, ("t_s", "temp_c"))
    q = np.deg2rad(np.stack([cols[f"q{j}_deg"] for j in range(1, 7)], axis=1))
    return ArmRecording(q, np.stack([cols["x_mm"], cols["y_mm"], cols["z_mm"]], axis=1), cols.get("t_s"),
                        cols.get("temp_c"))
