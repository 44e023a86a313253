"""Reading an arm's recording (any joint count, serial or branched) and its checks."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from calibench.recordings.csv_io import RecordingError, read_columns, read_header
from calibench.recordings.records import ArmRecording

ARM_REQUIRED = tuple(f"q{j}_deg" for j in range(1, 7)) + ("x_mm", "y_mm", "z_mm")
MAX_STD_MM = (
    1000.0  # an instrument's 1-sigma of a metre is a wrong unit or a corrupt value, not a reading
)
# a laser tracker's or a CMM's 1-sigma of a point is micrometres; one under a tenth of one is a
# wrong unit or a corrupt value, and a row weighted by it would outweigh every other
MIN_STD_MM = 1e-4
ARM_OPTIONAL = ("x_std_mm", "y_std_mm", "z_std_mm", "t_s", "temp_c", "tool")


def _joint_columns(path: Path, followers=()) -> int:
    """How many q<j>_deg columns the header names, q1 upward without a gap (a follower's column,
    which may be left out, counted as there)."""
    header = read_header(path)  # [] where it cannot be read: read_columns says why
    n = 0
    while f"q{n + 1}_deg" in header or n + 1 in followers:
        n += 1
    return n


def _joint_gap(path: Path, followers=()) -> str | None:
    """The first q<j>_deg missing below the highest one the header names (a gap; a follower's
    may be left out), or None."""
    header = read_header(path)
    named = [
        int(h[1:-4])
        for h in header
        if h.startswith("q") and h.endswith("_deg") and h[1:-4].isdigit()
    ]
    gap = [j for j in range(1, max(named, default=0)) if j not in named and j not in followers]
    return f"q{gap[0]}_deg" if gap else None


def _tools(path: Path, tool: np.ndarray, line: np.ndarray, n_tools: int | None) -> np.ndarray:
    """The ``tool`` column (1-based whole numbers, each one of the arm's ``n_tools``) as 0-based
    indices (n,)."""
    bad = np.flatnonzero((tool != np.round(tool)) | (tool < 1))
    if len(bad):
        raise RecordingError(
            f"{path} line {line[bad[0]]}: tool {tool[bad[0]]:g} is not a tool's number (1, 2, "
            "...: the arm description's [[tool]] tables in order)"
        )
    if n_tools is not None and tool.max() > n_tools:
        at = int(np.argmax(tool > n_tools))
        raise RecordingError(
            f"{path} line {line[at]}: tool {tool[at]:g}, but the arm has "
            f"{n_tools} tool{'s' if n_tools > 1 else ''} (its [[tool]] tables)"
        )
    return tool.astype(int) - 1


def _stds(path: Path, cols: dict, line: np.ndarray) -> np.ndarray | None:
    """The stated std (n, 3) mm of ``x_std_mm, y_std_mm, z_std_mm`` (all three or none), each
    positive, not finer than :data:`MIN_STD_MM` nor over :data:`MAX_STD_MM`; None without them."""
    std_cols = ("x_std_mm", "y_std_mm", "z_std_mm")
    present = [c for c in std_cols if c in cols]
    if present and len(present) < 3:
        raise RecordingError(
            f"{path}: {', '.join(present)} without the others: "
            "give all of x_std_mm, y_std_mm, z_std_mm"
        )
    if not present:
        return None
    std = np.stack([cols[c] for c in std_cols], axis=1)
    if np.any(std <= 0):
        bad = int(np.argmax(np.any(std <= 0, axis=1)))
        raise RecordingError(
            f"{path} line {line[bad]}: a std of zero or below (no instrument reads exactly: "
            "leave the std columns out to have the scatter estimated)"
        )
    if np.any(std < MIN_STD_MM):
        bad = int(np.argmax(np.any(std < MIN_STD_MM, axis=1)))
        raise RecordingError(
            f"{path} line {line[bad]}: a std of {std[bad].min():.3g} mm (under {MIN_STD_MM:g} "
            "mm, finer than any instrument measures a point: one such row would outweigh "
            "every other): a wrong unit or a corrupt value"
        )
    if np.any(std > MAX_STD_MM):
        raise RecordingError(
            f"{path} line {line[int(np.argmax(np.any(std > MAX_STD_MM, axis=1)))]}: a std of "
            f"{std.max():.3g} mm (over {MAX_STD_MM:g} mm): a wrong unit or a corrupt value"
        )
    return std


def load_arm_csv(
    path: str | Path,
    n_joints: int | None = None,
    max_rows: int | None = None,
    range_deg: np.ndarray | None = None,
    follows: np.ndarray | tuple | None = None,
    n_tools: int | None = None,
) -> ArmRecording:
    """Read an arm recording (docs/formats.md, "Arm recordings").

    Angles that are evidently radians (every |q| below 2 pi over a spread of postures) and
    positions that are evidently metres are refused: the format says degrees and millimetres.

    Parameters
    ----------
    path : str or Path
        The CSV: q1_deg..qN_deg, x_mm, y_mm, z_mm; optional x_std_mm, y_std_mm, z_std_mm (all
        three or none), t_s, temp_c.
    n_joints : int or None
        The arm's joint count; a recording with another count is refused. None: as many as the
        header names.
    max_rows : int or None
        Refuse longer recordings before converting them.
    range_deg : ndarray or None
        (n_joints, 2) the arm's joint ranges, deg; an arm whose every joint stays within 2 pi
        degrees cannot tell its degrees from radians, so its readings are taken as the format
        says.
    follows : ndarray or None
        (n_joints, n_joints) a branched arm's readings-to-angles matrix: a joint that follows
        others (its diagonal zero) needs no column, and what its column holds is ignored: its
        angle is made from the joints it follows.
    n_tools : int or None
        The arm's tools; a ``tool`` column naming another is refused. None: not checked.

    Returns
    -------
    ArmRecording
        q_rad (n, n_joints) (a follower's column its angle), xyz_mm (n, 3), xyz_std_mm (n, 3) or
        None, t_s and temp_c (n,) or None, tool (n,) 0-based or None.

    Raises
    ------
    RecordingError
        Any defect of the file, a gap in the joint columns, another joint count, radians,
        metres, an angle or a coordinate out of range, a std that is not positive or over a
        metre.
    """
    path = Path(path)
    F = None if follows is None else np.asarray(follows, float)
    followers = () if F is None else tuple(int(j) + 1 for j in np.flatnonzero(np.diag(F) == 0))
    found = _joint_columns(path, followers)
    n = n_joints if n_joints is not None else max(found, 1)
    gap = _joint_gap(path, followers)
    if gap:
        raise RecordingError(
            f"{path}: column {gap} is missing "
            "(the joint columns are q1_deg, q2_deg, ... without a gap)"
        )
    if n_joints is not None and found and found != n_joints:
        raise RecordingError(
            f"{path}: {found} joint column(s) (q1_deg..q{found}_deg) but the arm has "
            f"{n_joints} joints"
        )
    q_cols = tuple(f"q{j}_deg" for j in range(1, n + 1) if j not in followers)
    cols, line = read_columns(path, q_cols + ("x_mm", "y_mm", "z_mm"), ARM_OPTIONAL, max_rows)
    q_deg = np.zeros((len(line), n))
    for j in range(1, n + 1):
        if j not in followers:
            q_deg[:, j - 1] = cols[f"q{j}_deg"]
    for f in followers:  # from the joints it follows: its own column, if any, is not read
        assert F is not None
        q_deg[:, f - 1] = sum(F[f - 1, k] * q_deg[:, k] for k in np.flatnonzero(F[f - 1]))
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
    std = _stds(path, cols, line)
    tool = None if "tool" not in cols else _tools(path, cols["tool"], line, n_tools)
    return ArmRecording(np.deg2rad(q_deg), xyz, cols.get("t_s"), cols.get("temp_c"), std, tool)
