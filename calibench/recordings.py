"""Recordings: what an instrument records, the one interface between world and algorithms.

Simulated and real recordings load into the same small dataclasses of numpy arrays, with units
in the field names. Truth never goes in here. This module sits outside the four rooms and needs
only numpy (and scipy's rotations for a Stewart pose's Euler angles): a user with real data loads
a recording without importing the simulation.
"""

from __future__ import annotations

import csv
import dataclasses
from pathlib import Path

import numpy as np

from calibench.errors import BadInput


class RecordingError(BadInput):
    """A recording that cannot be used as it is (missing column, NaN, unreadable file)."""


def same_file(a: str | Path, b: str | Path) -> bool:
    """Whether two paths name one file (through links too); a path that does not exist yet is
    the other only if it resolves to it."""
    try:
        return Path(a).resolve() == Path(b).resolve() or Path(a).samefile(b)
    except OSError:
        return False


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


def _read_columns(
    path: str | Path, required: tuple, optional: tuple, max_rows: int | None = None
) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """Numeric columns of a CSV by name, and each data row's line in the file (n,); one clear
    RecordingError for any defect."""
    path = Path(path)
    try:
        with open(path, newline="", encoding="utf-8-sig") as f:
            rows = list(csv.reader(f))
    except IsADirectoryError:
        raise RecordingError(f"{path} is a folder, not a CSV file") from None
    except OSError as e:
        raise RecordingError(f"cannot read {path}: {e.strerror}") from None
    except UnicodeDecodeError:
        raise RecordingError(
            f"{path} is not UTF-8 text (Latin-1, or not a CSV at all?): save it as UTF-8 CSV"
        ) from None
    except csv.Error as e:
        raise RecordingError(f"{path} is not a CSV file ({e})") from None
    if not rows or not rows[0]:
        raise RecordingError(f"{path} is empty")
    header = [h.strip() for h in rows[0]]
    if len(header) == 1 and ";" in header[0]:
        raise RecordingError(
            f"{path} is separated by semicolons (a spreadsheet's export with decimal commas?): "
            "the format wants commas between values and points in numbers"
        )
    twice = sorted({h for h in header if h and header.count(h) > 1})
    if twice:
        raise RecordingError(
            f"{path}: column(s) {', '.join(twice)} named twice: which one is meant cannot be told"
        )
    missing = [c for c in required if c not in header]
    if missing:
        raise RecordingError(f"{path}: missing column(s) {', '.join(missing)}")
    # each data row with its line in the file (blank lines are skipped, not renumbered)
    lines = [i + 2 for i, r in enumerate(rows[1:]) if any(cell.strip() for cell in r)]
    body = [rows[i - 1] for i in lines]
    if not body:
        raise RecordingError(f"{path}: no data rows")
    # a value beyond the header's last column shifts every value after it (a decimal comma, a
    # stray separator): the columns can no longer be trusted (trailing empty cells are harmless)
    for i, r in enumerate(rows[1:]):
        if len(r) > len(header) and any(cell.strip() for cell in r[len(header) :]):
            raise RecordingError(
                f"{path} line {i + 2}: {len(r)} values, the header names {len(header)} columns "
                "(a decimal comma, or a separator too many?)"
            )
    if max_rows is not None and len(body) > max_rows:
        raise RecordingError(
            f"{path}: {len(body)} rows; this command takes at most {max_rows}: decimate the "
            "recording or split it"
        )
    fields = {}
    for name in required + optional:
        if name not in header:
            continue
        j = header.index(name)
        try:  # the whole column at once; the loop below only finds the bad cell
            cells = [r[j] for r in body]
            values = np.array(cells, dtype=float)
            if any(
                "_" in c for c in cells
            ):  # Python's float reads 1_000: a CSV number has no underscore
                raise ValueError
        except (IndexError, ValueError):
            for line, r in zip(lines, body):
                cell = r[j] if j < len(r) else ""
                try:
                    if "_" in cell:
                        raise ValueError
                    float(cell)
                except ValueError:
                    raise RecordingError(
                        f"{path} line {line}: column {name} is {cell!r}, not a number"
                    ) from None
            raise
        bad = ~np.isfinite(values)
        if bad.any():
            raise RecordingError(
                f"{path} line {lines[int(np.argmax(bad))]}: column {name} is not finite"
            )
        fields[name] = values
    line = np.array(lines)
    _check_common(path, fields, line)
    return fields, line


def _check_common(path, cols: dict, line: np.ndarray) -> None:
    """The optional columns every format shares: a machine's temperature, a load, a pass id.
    ``line`` (n,): each row's line in the file."""
    for name, lo, hi, what in (
        ("temp_c", -100.0, 200.0, "not a machine's temperature in deg C (-100 to 200)"),
        ("load_n", -1e6, 1e6, "over 100 t: a wrong unit or a corrupt value"),
    ):
        v = cols.get(name)
        if v is not None and np.any((v < lo) | (v > hi)):
            i = int(np.argmax((v < lo) | (v > hi)))
            raise RecordingError(f"{path} line {line[i]}: {name} is {v[i]:.3g}: {what}")
    run = cols.get("run")
    if run is not None and np.any(run != np.round(run)):
        i = int(np.argmax(run != np.round(run)))
        raise RecordingError(
            f"{path} line {line[i]}: run is {run[i]:g}; a pass id is a whole number"
        )


MAX_STAGE_MM = (
    5e4  # 50 m, beyond the largest gantry: a coordinate there is a wrong unit or a corrupt value
)


def load_stage_csv(path: str | Path, max_rows: int | None = None) -> StageRecording:
    """Read a stage recording; one clear RecordingError for any defect (a missing column, a
    value that is not a number or not finite, a coordinate beyond 50 m or every one within 2 mm
    (micrometres, metres), a direction other than -1, 0, +1). ``max_rows``: refuse longer recordings before converting them."""
    cols, line = _read_columns(path, StageRecording.REQUIRED, StageRecording.OPTIONAL, max_rows)
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
            f"{path}: every position lies within +-{np.abs(xy).max():.3g}: metres? the format wants "
            "millimetres (x_cmd_mm, ...)"
        )
    for name in ("dir_x", "dir_y"):
        if name in cols and not np.isin(cols[name], (-1.0, 0.0, 1.0)).all():
            i = int(np.argmax(~np.isin(cols[name], (-1.0, 0.0, 1.0))))
            raise RecordingError(
                f"{path} line {line[i]}: {name} is {cols[name][i]:g}; a direction is -1, 0 or +1"
            )
    return StageRecording(**cols)


@dataclasses.dataclass
class ArmRecording:
    """Postures of a serial arm and the point a reference instrument measured at each.

    q_rad : (n, n_joints) encoder readings, rad.
    xyz_mm : (n, 3) the measured point in the instrument's own frame, mm.
    xyz_std_mm : (n, 3) the instrument's 1-sigma per value, mm, or None.
    t_s, temp_c : (n,) seconds since start and machine temperature, or None.
    """

    q_rad: np.ndarray
    xyz_mm: np.ndarray
    t_s: np.ndarray | None = None
    temp_c: np.ndarray | None = None
    xyz_std_mm: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.q_rad)

    @property
    def n_joints(self) -> int:
        return self.q_rad.shape[1]

    def subset(self, rows: np.ndarray) -> ArmRecording:
        """The recording restricted to ``rows`` (indices or a boolean mask)."""
        pick = lambda v: None if v is None else v[rows]  # noqa: E731
        return ArmRecording(
            self.q_rad[rows],
            self.xyz_mm[rows],
            pick(self.t_s),
            pick(self.temp_c),
            pick(self.xyz_std_mm),
        )

    def to_csv(self, path) -> None:
        cols = [f"q{j}_deg" for j in range(1, self.n_joints + 1)] + ["x_mm", "y_mm", "z_mm"]
        data = [np.rad2deg(self.q_rad), self.xyz_mm]
        if self.xyz_std_mm is not None:
            cols += ["x_std_mm", "y_std_mm", "z_std_mm"]
            data.append(self.xyz_std_mm)
        for name in ("t_s", "temp_c"):
            if getattr(self, name) is not None:
                cols.append(name)
                data.append(getattr(self, name)[:, None])
        np.savetxt(
            path, np.hstack(data), delimiter=",", header=",".join(cols), comments="", fmt="%.9g"
        )


ARM_REQUIRED = tuple(f"q{j}_deg" for j in range(1, 7)) + ("x_mm", "y_mm", "z_mm")
MAX_STD_MM = (
    1000.0  # an instrument's 1-sigma of a metre is a wrong unit or a corrupt value, not a reading
)
ARM_OPTIONAL = ("x_std_mm", "y_std_mm", "z_std_mm", "t_s", "temp_c")


def _joint_columns(path: Path) -> int:
    """How many q<j>_deg columns the header names, q1 upward without a gap."""
    try:
        with open(path, newline="", encoding="utf-8-sig") as f:
            header = [h.strip() for h in next(csv.reader(f), [])]
    except (OSError, UnicodeDecodeError):
        return 0  # _read_columns says what is wrong
    n = 0
    while f"q{n + 1}_deg" in header:
        n += 1
    return n


def _joint_gap(path: Path) -> str | None:
    """The first q<j>_deg missing below the highest one the header names (a gap), or None."""
    try:
        with open(path, newline="", encoding="utf-8-sig") as f:
            header = [h.strip() for h in next(csv.reader(f), [])]
    except (OSError, UnicodeDecodeError):
        return None
    named = [
        int(h[1:-4])
        for h in header
        if h.startswith("q") and h.endswith("_deg") and h[1:-4].isdigit()
    ]
    gap = [j for j in range(1, max(named, default=0)) if j not in named]
    return f"q{gap[0]}_deg" if gap else None


def load_arm_csv(
    path: str | Path,
    n_joints: int | None = None,
    max_rows: int | None = None,
    range_deg: np.ndarray | None = None,
) -> ArmRecording:
    """Read an arm recording (CONTRACT, "Arms"): q1_deg..qN_deg, x_mm, y_mm, z_mm; optional
    x_std_mm, y_std_mm, z_std_mm, t_s, temp_c.

    ``n_joints``: the arm's joint count; a recording with another count is refused. Angles that
    are evidently radians (every |q| below 2 pi over a spread of postures) and positions that are
    evidently metres are refused too: the format says degrees and millimetres. ``range_deg``
    (n_joints, 2): the arm's joint ranges; an arm whose every joint stays within 2 pi degrees
    cannot tell its degrees from radians, so its readings are taken as the format says.
    """
    path = Path(path)
    found = _joint_columns(path)
    n = n_joints if n_joints is not None else max(found, 1)
    gap = _joint_gap(path)
    if gap:
        raise RecordingError(
            f"{path}: column {gap} is missing (the joint columns are q1_deg, q2_deg, ... without a gap)"
        )
    if n_joints is not None and found and found != n_joints:
        raise RecordingError(
            f"{path}: {found} joint column(s) (q1_deg..q{found}_deg) but the arm has "
            f"{n_joints} joints"
        )
    q_cols = tuple(f"q{j}_deg" for j in range(1, n + 1))
    cols, line = _read_columns(path, q_cols + ("x_mm", "y_mm", "z_mm"), ARM_OPTIONAL, max_rows)
    q_deg = np.stack([cols[c] for c in q_cols], axis=1)
    xyz = np.stack([cols["x_mm"], cols["y_mm"], cols["z_mm"]], axis=1)
    tiny_arm = range_deg is not None and np.abs(np.asarray(range_deg, float)).max() <= 2 * np.pi
    if (
        len(q_deg) >= 10
        and np.ptp(q_deg, axis=0).max() > 0.5
        and np.abs(q_deg).max() <= 2 * np.pi
        and not tiny_arm
    ):
        raise RecordingError(
            f"{path}: every joint angle lies within +-{np.abs(q_deg).max():.2f}: these look like "
            "radians, the format wants degrees (q<j>_deg)"
        )
    if np.abs(q_deg).max() > 3600:
        raise RecordingError(
            f"{path}: a joint angle of {np.abs(q_deg).max():.3g} deg: not an angle in degrees"
        )
    # the arm moved (a joint over 20 deg) yet its point stayed within 5: the unit, not the arm
    if len(xyz) >= 10 and np.ptp(q_deg, axis=0).max() > 20 and 0 < np.ptp(xyz, axis=0).max() < 5.0:
        raise RecordingError(
            f"{path}: the measured points span only {np.ptp(xyz, axis=0).max():.3g} in x, y and z: "
            "metres? the format wants millimetres (x_mm, y_mm, z_mm)"
        )
    if np.abs(xyz).max() > 1e6:
        raise RecordingError(
            f"{path}: a measured coordinate of {np.abs(xyz).max():.3g} mm (over a kilometre): "
            "wrong unit or a corrupt value"
        )
    std = None
    std_cols = ("x_std_mm", "y_std_mm", "z_std_mm")
    present = [c for c in std_cols if c in cols]
    if present and len(present) < 3:
        raise RecordingError(
            f"{path}: {', '.join(present)} without the others: give all of x_std_mm, y_std_mm, z_std_mm"
        )
    if present:
        std = np.stack([cols[c] for c in std_cols], axis=1)
        if np.any(std <= 0):
            raise RecordingError(
                f"{path} line {line[int(np.argmax(np.any(std <= 0, axis=1)))]}: a std of zero or below "
                "(no instrument reads exactly: leave the std columns out to have the scatter estimated)"
            )
        if np.any(std > MAX_STD_MM):
            raise RecordingError(
                f"{path} line {line[int(np.argmax(np.any(std > MAX_STD_MM, axis=1)))]}: a std of "
                f"{std.max():.3g} mm (over {MAX_STD_MM:g} mm): a wrong unit or a corrupt value"
            )
    return ArmRecording(np.deg2rad(q_deg), xyz, cols.get("t_s"), cols.get("temp_c"), std)


@dataclasses.dataclass
class AxisRun:
    """A bidirectional positioning test of one axis (ISO 230-2), one row per reading.

    target_mm : (k,) the target position P_i of each reading, mm.
    run : (k,) which run (1, 2, ...) the reading belongs to.
    direction : (k,) +1 approaching in the positive direction, -1 in the negative one.
    deviation_um : (k,) actual minus target, um.
    """

    target_mm: np.ndarray
    run: np.ndarray
    direction: np.ndarray
    deviation_um: np.ndarray

    def __len__(self) -> int:
        return len(self.target_mm)

    def tables(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """targets (m,) ascending, and the deviations up and down, (m, n) each: row i for target
        i, column j for the j-th run of that direction (in the order of ``run``). Raises
        RecordingError when a target lacks a direction or the runs per target differ."""
        targets = np.unique(self.target_mm)
        cols = {}
        for d, word in ((+1, "positive"), (-1, "negative")):
            m = self.direction == d
            counts = [int(np.sum(m & (self.target_mm == t))) for t in targets]
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
        return targets, cols[+1], cols[-1]


def load_axis_run(path: str | Path) -> AxisRun:
    """Read a bidirectional run (CONTRACT, "iso230"): target_mm, run, direction and either
    deviation_um or actual_mm."""
    path = Path(path)
    cols, line = _read_columns(
        path, ("target_mm", "run", "direction"), ("deviation_um", "actual_mm")
    )
    if "deviation_um" in cols:
        dev = cols["deviation_um"]
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
    return AxisRun(cols["target_mm"], cols["run"], d.astype(int), dev)


def _write_csv(path, cols: list[str], data: list[np.ndarray]) -> None:
    np.savetxt(
        path, np.column_stack(data), delimiter=",", header=",".join(cols), comments="", fmt="%.10g"
    )


@dataclasses.dataclass
class ScannerRecording:
    """Turns of a rotary probe scanner over its calibration artefact (CONTRACT, "Recordings of
    the other instruments").

    turn : (n,) integer turn id of each sample.
    theta_rad : (n,) the table encoder's angle, rad.
    rho_mm : (n,) the probe's reading, mm.
    t_s, temp_c : (n,) or None.
    """

    turn: np.ndarray
    theta_rad: np.ndarray
    rho_mm: np.ndarray
    t_s: np.ndarray | None = None
    temp_c: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.rho_mm)

    def to_csv(self, path) -> None:
        cols, data = (
            ["turn", "theta_deg", "rho_mm"],
            [self.turn, np.rad2deg(self.theta_rad), self.rho_mm],
        )
        for name in ("t_s", "temp_c"):
            if getattr(self, name) is not None:
                cols.append(name)
                data.append(getattr(self, name))
        _write_csv(path, cols, data)


MAX_RHO_MM = 1000.0  # a spectacle frame's scanner reads within a few cm of its axis


def load_scanner_csv(path: str | Path, max_rows: int | None = None) -> ScannerRecording:
    """Read a probe-scanner recording: turn, theta_deg, rho_mm; optional t_s, temp_c. Refused:
    a turn that is not an integer, a reading that is not positive or beyond a metre."""
    cols, line = _read_columns(path, ("turn", "theta_deg", "rho_mm"), ("t_s", "temp_c"), max_rows)
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
            f"{path} line {line[i]}: rho_mm is {cols['rho_mm'][i]:.3g}: over {MAX_RHO_MM:g} mm from "
            "the table's axis, a wrong unit (um?) or a corrupt value"
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


STEWART_POSE = ("x_mm", "y_mm", "z_mm", "rx_deg", "ry_deg", "rz_deg")


@dataclasses.dataclass
class StewartRecording:
    """Poses of a Stewart platform: the legs' readings and the pose a tracker measured
    (CONTRACT, "Recordings of the other instruments").

    readings_mm : (n, 6) the legs' length readings, mm.
    R : (n, 3, 3) the platform frame's orientation in the tracker frame.
    t_mm : (n, 3) the platform frame's origin in the tracker frame, mm.
    direction : (n, 6) +1 / -1 / 0: the way each leg last moved, or None.
    t_s, temp_c, load_n : (n,) or None.
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

    def to_csv(self, path) -> None:
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
        _write_csv(path, cols, data)


def load_stewart_csv(path: str | Path, max_rows: int | None = None) -> StewartRecording:
    """Read a Stewart recording: l1_mm..l6_mm and the tracker's pose x_mm, y_mm, z_mm, rx_deg,
    ry_deg, rz_deg (XYZ intrinsic Euler angles); optional t_s, temp_c, dir_1..dir_6 (all six or
    none), load_n."""
    from scipy.spatial.transform import Rotation

    legs = tuple(f"l{i}_mm" for i in range(1, 7))
    dirs = tuple(f"dir_{i}" for i in range(1, 7))
    cols, line = _read_columns(
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
    if np.abs(ang).max() > 360:
        raise RecordingError(
            f"{path}: an angle of {np.abs(ang).max():.3g} deg in rx/ry/rz: not degrees"
        )
    t = np.stack([cols[c] for c in ("x_mm", "y_mm", "z_mm")], axis=1)
    if np.abs(t).max() > 1e6:
        raise RecordingError(
            f"{path}: a coordinate of {np.abs(t).max():.3g} mm (over a kilometre): wrong unit"
        )
    return StewartRecording(
        np.stack([cols[c] for c in legs], axis=1),
        Rotation.from_euler("XYZ", ang, degrees=True).as_matrix(),
        t,
        cols.get("t_s"),
        cols.get("temp_c"),
        direction,
        cols.get("load_n"),
    )
