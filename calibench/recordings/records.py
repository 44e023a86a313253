"""The recording types: what each instrument records, small dataclasses of numpy arrays with units
in the field names, and how each writes itself in its docs/formats.md format."""

from __future__ import annotations

import csv
import dataclasses
from pathlib import Path
from typing import Protocol

import numpy as np

from calibench.recordings.csv_io import RecordingError, write_csv

# a Stewart platform's pose as the tracker measured it (XYZ intrinsic Euler angles)
STEWART_POSE = ("x_mm", "y_mm", "z_mm", "rx_deg", "ry_deg", "rz_deg")


def _rows_of(recording, rows: np.ndarray):
    """A recording whose every field is an array of its rows (or None, absent) restricted to
    ``rows``: indices (k,) or a boolean mask (n,)."""
    return dataclasses.replace(
        recording,
        **{
            f.name: None if (v := getattr(recording, f.name)) is None else v[rows]
            for f in dataclasses.fields(recording)
        },
    )


class Recording(Protocol):
    """What every recording type is to a command that writes one: its rows, and its CSV in
    docs/formats.md's format."""

    def __len__(self) -> int: ...

    def to_csv(self, path: str | Path) -> None: ...


@dataclasses.dataclass
class CameraViews:
    """Views of a chessboard by one camera.

    Attributes
    ----------
    image_size : tuple of int
        (width, height) px.
    names : list of str
        One label per view (file name or station).
    images : list of ndarray or None
        (height, width, 3) uint8 each, or None (analytic fidelity: no pixels).
    corners_px : ndarray or None
        (n_views, n_corners, 2) the detector's output, NaN where a view was not detected; filled
        by the detector for images, by the sensor model otherwise.
    """

    image_size: tuple[int, int]
    names: list[str]
    images: list[np.ndarray] | None = None
    corners_px: np.ndarray | None = None


@dataclasses.dataclass
class StageRecording:
    """Stations of a two-axis stage: commanded and measured positions, docs/formats.md format.

    Attributes
    ----------
    x_cmd_mm, y_cmd_mm : ndarray
        (n,) commanded position, mm.
    x_meas_mm, y_meas_mm : ndarray
        (n,) position measured by the reference instrument, mm.
    t_s, dir_x, dir_y, temp_c, run : ndarray or None
        (n,) seconds since start, direction of the last approach on each axis (+1 / -1, 0
        unknown), machine temperature (deg C), integer pass id; None when absent.
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
        """(n,) measured minus commanded X, mm."""
        return self.x_meas_mm - self.x_cmd_mm

    @property
    def y_err_mm(self) -> np.ndarray:
        """(n,) measured minus commanded Y, mm."""
        return self.y_meas_mm - self.y_cmd_mm

    def to_csv(self, path: str | Path) -> None:
        """Write docs/formats.md's stage CSV (nine significant digits), the optional columns
        present.

        Parameters
        ----------
        path : str or Path
            The file to write (replaced).
        """
        cols = [c for c in self.REQUIRED + self.OPTIONAL if getattr(self, c) is not None]
        data = np.column_stack([getattr(self, c) for c in cols])
        with open(path, "w", newline="") as f:
            w = csv.writer(f)
            w.writerow(cols)
            w.writerows([[f"{v:.9g}" for v in row] for row in data])


@dataclasses.dataclass
class ArmRecording:
    """Postures of an arm and the point a reference instrument measured at each.

    Attributes
    ----------
    q_rad : ndarray
        (n, n_joints) encoder readings, rad.
    xyz_mm : ndarray
        (n, 3) the measured point in the instrument's own frame, mm.
    t_s, temp_c : ndarray or None
        (n,) seconds since start and machine temperature (deg C).
    xyz_std_mm : ndarray or None
        (n, 3) the instrument's 1-sigma per value, mm.
    tool : ndarray or None
        (n,) int, which of a branched arm's tools each row measures, 0-based (the CSV's ``tool``
        column is 1-based); None: every row the first.
    """

    q_rad: np.ndarray
    xyz_mm: np.ndarray
    t_s: np.ndarray | None = None
    temp_c: np.ndarray | None = None
    xyz_std_mm: np.ndarray | None = None
    tool: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.q_rad)

    @property
    def n_joints(self) -> int:
        """The arm's joint count (columns of ``q_rad``)."""
        return self.q_rad.shape[1]

    def subset(self, rows: np.ndarray) -> ArmRecording:
        """The recording restricted to some rows.

        Parameters
        ----------
        rows : ndarray
            Indices (k,) or a boolean mask (n,).

        Returns
        -------
        ArmRecording
            The k rows, every present field with them.
        """
        return _rows_of(self, rows)

    def to_csv(self, path) -> None:
        """Write docs/formats.md's arm CSV: q1_deg..qN_deg, x_mm, y_mm, z_mm and what is present of
        x_std_mm, y_std_mm, z_std_mm, t_s, temp_c, tool (1-based) (nine significant digits).

        Parameters
        ----------
        path : str or Path
            The file to write (replaced).
        """
        cols = [f"q{j}_deg" for j in range(1, self.n_joints + 1)] + ["x_mm", "y_mm", "z_mm"]
        data = [np.rad2deg(self.q_rad), self.xyz_mm]
        if self.xyz_std_mm is not None:
            cols += ["x_std_mm", "y_std_mm", "z_std_mm"]
            data.append(self.xyz_std_mm)
        for name in ("t_s", "temp_c"):
            if getattr(self, name) is not None:
                cols.append(name)
                data.append(getattr(self, name)[:, None])
        if self.tool is not None:
            cols.append("tool")
            data.append(np.asarray(self.tool, float)[:, None] + 1)
        np.savetxt(
            path, np.hstack(data), delimiter=",", header=",".join(cols), comments="", fmt="%.9g"
        )


@dataclasses.dataclass
class AxisRun:
    """A bidirectional positioning test of one axis (ISO 230-2), one row per reading.

    Attributes
    ----------
    target_mm : ndarray
        (k,) the target position P_i of each reading, mm.
    run : ndarray
        (k,) which run (1, 2, ...) the reading belongs to.
    direction : ndarray
        (k,) +1 approaching in the positive direction, -1 in the negative one.
    deviation_um : ndarray
        (k,) actual minus target, um.
    """

    target_mm: np.ndarray
    run: np.ndarray
    direction: np.ndarray
    deviation_um: np.ndarray

    def __len__(self) -> int:
        return len(self.target_mm)

    def tables(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The readings as ISO 230-2's tables, one per direction.

        Returns
        -------
        targets : ndarray
            (m,) the targets, ascending, mm.
        up, down : ndarray
            (m, r) deviations approached in the positive and the negative direction, um: row i
            for target i, column j for the j-th run of that direction (in the order of ``run``).

        Raises
        ------
        RecordingError
            When a target lacks a direction or the runs per target differ.
        """
        targets = np.unique(self.target_mm)
        cols = {}
        for d, word in ((+1, "positive"), (-1, "negative")):
            m = self.direction == d
            # readings per target in one pass (a comparison per target was quadratic: 100,000
            # targets took 45 s)
            counts = np.bincount(
                np.searchsorted(targets, self.target_mm[m]), minlength=len(targets)
            ).tolist()
            if min(counts) == 0:
                t = targets[counts.index(0)]
                raise RecordingError(
                    f"target {t:g} mm has no reading approached in the {word} direction: a "
                    "bidirectional run needs both at every target"
                )
            if len(set(counts)) > 1:
                raise RecordingError(
                    f"the {word} direction has {min(counts)} to {max(counts)} readings per target: "
                    "every target needs the same number of runs"
                )
            order = np.lexsort((self.run[m], self.target_mm[m]))
            cols[d] = self.deviation_um[m][order].reshape(len(targets), counts[0])
        if cols[+1].shape != cols[-1].shape:
            raise RecordingError(
                f"{cols[+1].shape[1]} runs approach each target in the positive direction and "
                f"{cols[-1].shape[1]} in the negative: ISO 230-2 pairs them, as many each way"
            )
        return targets, cols[+1], cols[-1]


@dataclasses.dataclass
class ScannerRecording:
    """Turns of a rotary probe scanner over its calibration artefact (docs/formats.md,
    "Recordings").

    Attributes
    ----------
    turn : ndarray
        (n,) integer turn id of each sample.
    theta_rad : ndarray
        (n,) the table encoder's angle, rad.
    rho_mm : ndarray
        (n,) the probe's reading, mm.
    t_s, temp_c : ndarray or None
        (n,) seconds since start and machine temperature (deg C).
    """

    turn: np.ndarray
    theta_rad: np.ndarray
    rho_mm: np.ndarray
    t_s: np.ndarray | None = None
    temp_c: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.rho_mm)

    def subset(self, rows: np.ndarray) -> ScannerRecording:
        """The recording restricted to ``rows``: indices (k,) or a boolean mask (n,)."""
        return _rows_of(self, rows)

    def to_csv(self, path) -> None:
        """Write docs/formats.md's probe-scanner CSV: turn, theta_deg, rho_mm and what is present of
        t_s, temp_c (ten significant digits).

        Parameters
        ----------
        path : str or Path
            The file to write (replaced).
        """
        cols, data = (
            ["turn", "theta_deg", "rho_mm"],
            [self.turn, np.rad2deg(self.theta_rad), self.rho_mm],
        )
        for name in ("t_s", "temp_c"):
            if getattr(self, name) is not None:
                cols.append(name)
                data.append(getattr(self, name))
        write_csv(path, cols, data)


@dataclasses.dataclass
class StewartRecording:
    """Poses of a Stewart platform: the legs' readings and the pose a tracker measured
    (docs/formats.md, "Recordings").

    Attributes
    ----------
    readings_mm : ndarray
        (n, 6) the legs' length readings, mm.
    R : ndarray
        (n, 3, 3) the platform frame's orientation in the tracker frame.
    t_mm : ndarray
        (n, 3) the platform frame's origin in the tracker frame, mm.
    t_s, temp_c, load_n : ndarray or None
        (n,) seconds since start, machine temperature (deg C), payload (N).
    direction : ndarray or None
        (n, 6) +1 / -1 / 0: the way each leg last moved.
    """

    readings_mm: np.ndarray
    R: np.ndarray
    t_mm: np.ndarray
    t_s: np.ndarray | None = None
    temp_c: np.ndarray | None = None
    direction: np.ndarray | None = None
    load_n: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.readings_mm)

    def subset(self, rows: np.ndarray) -> StewartRecording:
        """The recording restricted to ``rows``: indices (k,) or a boolean mask (n,)."""
        return _rows_of(self, rows)

    def to_csv(self, path) -> None:
        """Write docs/formats.md's Stewart CSV: l1_mm..l6_mm, the pose (x_mm, y_mm, z_mm, rx_deg,
        ry_deg, rz_deg: XYZ intrinsic Euler angles) and what is present of t_s, temp_c,
        dir_1..dir_6, load_n (ten significant digits).

        Parameters
        ----------
        path : str or Path
            The file to write (replaced).
        """
        from scipy.spatial.transform import Rotation

        cols = [f"l{i}_mm" for i in range(1, 7)] + list(STEWART_POSE)
        data = [
            self.readings_mm,
            self.t_mm,
            Rotation.from_matrix(self.R).as_euler("XYZ", degrees=True),
        ]
        for name in ("t_s", "temp_c"):
            if getattr(self, name) is not None:
                cols.append(name)
                data.append(getattr(self, name))
        if self.direction is not None:
            cols += [f"dir_{i}" for i in range(1, 7)]
            data.append(self.direction)
        if self.load_n is not None:
            cols.append("load_n")
            data.append(self.load_n)
        write_csv(path, cols, data)
