"""Scene ``arm-cmm``: what the arm is. Any serial arm described by an ARM.toml, with its masses;
its MJCF (with a laser tracker, a cone and a length bar) is :mod:`calibench.scenes.arm_mjcf`.

An arm is data (docs/formats.md, "Arm descriptions"): :func:`load_arm` reads an ARM.toml (or a
built-in name: ``arm-cmm`` is the seed's 6-joint arm CMM, ``ur10`` the Universal Robots UR10) into
an :class:`ArmDescription`, checking every field (one :class:`ArmFileError` line naming it). The
description is the one source of an arm's numbers: the simulation builds its twin from it, and
the scenarios give the estimators its kinematic fields
(:func:`calibench.scenarios.arm_cmm.arms.chain_of`).
"""

from __future__ import annotations

import dataclasses
import math
import os
import tomllib
from pathlib import Path

import numpy as np

from calibench.errors import BadInput
from calibench.scenes import arm_tree

ARMS_DIR = Path(__file__).resolve().parent / "arms"
DEFAULT_ARM = "arm-cmm"  # the seed's 6-joint arm CMM, the arm a run builds when none is named
BUILTIN = {DEFAULT_ARM: ARMS_DIR / "arm_cmm.toml", "ur10": ARMS_DIR / "ur10.toml"}
MAX_JOINTS = 12


class ArmFileError(BadInput):
    """An arm description that cannot be used (one line naming the file and the field)."""


@dataclasses.dataclass(frozen=True)
class ArmDescription:
    """A serial arm: nominal kinematics (mm, rad), masses, the tool.

    a_mm, d_mm, alpha_rad, theta_rad : (N,) per joint, base to flange.
    range_rad : (N, 2) the postures a simulation draws from.
    mass_kg : (N,) or None; com_mm : (N, 3) or None, in each link's own frame.
    tool_mm : (3,) the measured point in the flange frame (a first guess on real data).
    coupling : (N, N) or None: an arm driven through cables or differentials, joint angles =
        coupling @ motor angles (None: each motor turns its own joint).
    cable_stiffness_nm_per_rad : (N,) or None: each motor's cable, seen at the motor (inf: rigid);
        the cables stretch under the joints' loads carried back through the coupling.
    parent : (N,) or None: a branched arm's joints' parents (0 the base, k joint k, 1-based);
        None for a serial arm.
    follows : (N, N) or None: joint angles = follows @ readings, a joint without an encoder of
        its own (its row the coefficients of the joints it follows, its column zero); None when
        every joint reads its own.
    tools_mm, tools_joint, tools_mass_kg : (T, 3), (T,), (T,) or None: several tools (or one on
        another joint than the last), each's point in its joint's link frame, that joint
        (1-based) and its mass; None for the one tool of ``tool_mm`` on the last joint (where
        several, ``tool_mm`` and ``tool_mass_kg`` are the first's).
    """

    name: str
    convention: str
    a_mm: tuple
    d_mm: tuple
    alpha_rad: tuple
    theta_rad: tuple
    range_rad: tuple
    tool_mm: tuple = (0.0, 0.0, 0.0)
    mass_kg: tuple | None = None
    com_mm: tuple | None = None
    tool_mass_kg: float = 0.0
    gravity_m_s2: tuple = (0.0, 0.0, -9.81)
    coupling: tuple | None = None
    cable_stiffness_nm_per_rad: tuple | None = None
    parent: tuple | None = None
    follows: tuple | None = None
    tools_mm: tuple | None = None
    tools_joint: tuple | None = None
    tools_mass_kg: tuple | None = None
    source: str = ""

    @property
    def n_joints(self) -> int:
        """The number of joints."""
        return len(self.a_mm)

    @property
    def has_masses(self) -> bool:
        """Whether every joint's link has a mass and a centre of mass."""
        return self.mass_kg is not None

    @property
    def n_tools(self) -> int:
        """The number of tools (measured points)."""
        return 1 if self.tools_mm is None else len(self.tools_mm)

    @property
    def branched(self) -> bool:
        """Whether the arm is more than one serial chain to one tool at its flange: joints on
        other parents, followers, several tools or a tool elsewhere."""
        return self.parent is not None or self.follows is not None or self.tools_mm is not None

    def parents(self) -> np.ndarray:
        """(N,) int each joint's parent (0 the base, k joint k)."""
        return np.arange(self.n_joints) if self.parent is None else np.array(self.parent, int)

    def tool_offsets(self) -> np.ndarray:
        """(T, 3) each tool's point in its joint's link frame, mm."""
        return np.array([self.tool_mm] if self.tools_mm is None else self.tools_mm, float)

    def tool_joints(self) -> np.ndarray:
        """(T,) int the joint (1-based) whose link carries each tool."""
        return np.array([self.n_joints] if self.tools_joint is None else self.tools_joint, int)

    def tool_masses(self) -> np.ndarray:
        """(T,) each tool's mass, kg."""
        return np.array(
            [self.tool_mass_kg] if self.tools_mass_kg is None else self.tools_mass_kg, float
        )

    def followers(self) -> list[int]:
        """The joints (1-based) that follow others (no encoder of their own)."""
        if self.follows is None:
            return []
        return [j + 1 for j in range(self.n_joints) if self.follows[j][j] == 0.0]

    def joint_angles(self, readings: np.ndarray) -> np.ndarray:
        """The joints' angles (n, N) at ``readings`` (n, N): each follower's from the joints it
        follows (its own column ignored)."""
        q = np.array(readings, float)
        for f in self.followers():
            row = self.follows[f - 1]  # type: ignore[index]
            q[:, f - 1] = sum(a * q[:, k] for k, a in enumerate(row) if a != 0.0)
        return q

    def motor_to_joint(self) -> np.ndarray:
        """(N, N) joint angles = this @ motor angles (the identity without a coupling)."""
        return np.eye(self.n_joints) if self.coupling is None else np.array(self.coupling)

    def cable_compliance(self) -> np.ndarray:
        """(N,) rad / N m of each motor's cable (0: rigid, or no cables described)."""
        k = self.cable_stiffness_nm_per_rad
        return np.zeros(self.n_joints) if k is None else 1.0 / np.asarray(k, float)

    def nominal(self) -> np.ndarray:
        """(N, 5) the drawing's a, d (mm), alpha, theta, beta (rad) per joint (beta = 0)."""
        return np.stack(
            [self.a_mm, self.d_mm, self.alpha_rad, self.theta_rad, np.zeros(self.n_joints)], axis=1
        )

    @property
    def reach_mm(self) -> float:
        """An upper bound of the tool point's distance from the first joint's axis."""
        return float(
            np.sum(np.abs(self.a_mm))
            + np.sum(np.abs(self.d_mm[1:]))
            + np.linalg.norm(self.tool_offsets(), axis=1).max()
        )

    def parallel_pairs(self, tol_rad: float = math.radians(5)) -> list[tuple[int, int]]:
        """Consecutive joints (1-based; a joint and its parent on a branched arm) whose axes are
        (nearly) parallel, nominally."""
        al = np.asarray(self.alpha_rad)
        parent = self.parents()
        pairs = []
        for c in range(1, self.n_joints):
            p = int(parent[c])  # joint c + 1's parent, 1-based (0: the base, no pair)
            if p == 0:
                continue
            # dh: alpha_p turns z_{p-1} into z_p; mdh: alpha_c turns z_p into z_c
            twist = al[p - 1] if self.convention == "dh" else al[c]
            if abs(math.sin(twist)) < math.sin(tol_rad):
                pairs.append((p, c + 1))
        return pairs


_LOADED: dict[
    tuple, ArmDescription
] = {}  # by (path as given, mtime, size): a study's trials read it once


def load_arm(spec: str | Path) -> ArmDescription:
    """An ARM.toml by path, or a built-in arm by name (``arm-cmm``, ``ur10``)."""
    path = BUILTIN.get(str(spec), Path(spec))
    try:
        st = path.stat()
        # the path as given, where it was given (resolving it costs more than a trial's prior)
        key = (
            str(path) if path.is_absolute() else (os.getcwd(), str(path)),
            st.st_mtime_ns,
            st.st_size,
        )
        if key in _LOADED:
            return _LOADED[key]
        # an editor's UTF-8 byte-order mark read past, as a run's config's is
        table = tomllib.loads(path.read_bytes().removeprefix(b"\xef\xbb\xbf").decode("utf-8"))
    except FileNotFoundError:
        known = ", ".join(BUILTIN)
        raise ArmFileError(f"arm {spec}: no such file (or built-in arm: {known})") from None
    except OSError as e:
        raise ArmFileError(f"cannot read arm {path}: {e.strerror}") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as e:
        raise ArmFileError(f"arm {path} is not valid TOML: {e}") from None
    except RecursionError:
        raise ArmFileError(f"arm {path} is nested too deep to read: not an arm's file") from None
    if not table:
        raise ArmFileError(
            f'arm {path} is empty: it describes no arm (see docs/formats.md, "Arm descriptions")'
        )
    _LOADED[key] = arm = arm_from_table(table, str(path))
    return arm


def _number(table: dict, key: str, where: str, default=None, lo=-math.inf, hi=math.inf) -> float:
    if key not in table:
        if default is None:
            raise ArmFileError(f"{where}: missing field {key}")
        return default
    v = table[key]
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise ArmFileError(f"{where}: {key} must be a finite number, not {v!r}")
    if not lo <= v <= hi:
        raise ArmFileError(f"{where}: {key} = {v} is out of range [{lo}, {hi}]")
    return float(v)


def _vector(
    table: dict, key: str, where: str, n: int, default=None, bound: float = math.inf
) -> tuple:
    if key not in table:
        if default is None:
            raise ArmFileError(f"{where}: missing field {key}")
        return tuple(default)
    v = table[key]
    if (
        not isinstance(v, list)
        or len(v) != n
        or not all(
            isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) for x in v
        )
    ):
        raise ArmFileError(f"{where}: {key} must be a list of {n} finite numbers, not {v!r}")
    if any(abs(x) > bound for x in v):
        raise ArmFileError(f"{where}: {key} = {v} is out of range (each within +-{bound:g})")
    return tuple(float(x) for x in v)


def arm_from_table(t: dict, where: str = "arm") -> ArmDescription:
    """Validate a parsed ARM.toml; every defect is one ArmFileError naming the field."""
    known = {"name", "convention", "gravity_m_s2", "joint", "tool", "transmission"}
    extra = set(t) - known
    if extra:
        raise ArmFileError(
            f"{where}: unknown field(s) {', '.join(sorted(extra))} (known: "
            f"{', '.join(sorted(known))})"
        )
    name = t.get("name", Path(where).stem)
    if not isinstance(name, str) or not name.strip():
        raise ArmFileError(f"{where}: name must be a text")
    if (
        not name.isprintable()
    ):  # a newline or a tab would split or shift every line that names the arm
        raise ArmFileError(
            f"{where}: name {name!r} holds a control character (a newline, a tab): one printable "
            "line"
        )
    conv = t.get("convention")
    if conv not in ("dh", "mdh"):
        raise ArmFileError(f'{where}: convention must be "dh" or "mdh", not {conv!r}')
    joints = t.get("joint")
    if not isinstance(joints, list) or not joints or not all(isinstance(j, dict) for j in joints):
        raise ArmFileError(f"{where}: no [[joint]] tables (one per joint, base to flange)")
    if len(joints) > MAX_JOINTS:
        raise ArmFileError(f"{where}: {len(joints)} joints; at most {MAX_JOINTS}")
    a, d, al, th, rng, mass, com = [], [], [], [], [], [], []
    jkeys = {
        "a_mm",
        "d_mm",
        "alpha_deg",
        "theta_deg",
        "range_deg",
        "mass_kg",
        "com_mm",
        "parent",
        "follows",
    }
    for i, j in enumerate(joints, 1):
        w = f"{where}: joint {i}"
        extra = set(j) - jkeys
        if extra:
            raise ArmFileError(
                f"{w}: unknown field(s) {', '.join(sorted(extra))} (known: "
                f"{', '.join(sorted(jkeys))})"
            )
        a.append(_number(j, "a_mm", w, lo=-1e5, hi=1e5))
        d.append(_number(j, "d_mm", w, lo=-1e5, hi=1e5))
        al.append(math.radians(_number(j, "alpha_deg", w, lo=-360, hi=360)))
        th.append(math.radians(_number(j, "theta_deg", w, default=0.0, lo=-360, hi=360)))
        lo, hi = _vector(j, "range_deg", w, 2, default=(-180.0, 180.0))
        if not -720 <= lo < hi <= 720:
            raise ArmFileError(f"{w}: range_deg must be [low, high] with -720 <= low < high <= 720")
        rng.append((math.radians(lo), math.radians(hi)))
        has_m, has_c = "mass_kg" in j, "com_mm" in j
        if has_m != has_c:
            raise ArmFileError(
                f"{w}: mass_kg and com_mm go together (the gravity model needs both)"
            )
        if has_m:
            mass.append(_number(j, "mass_kg", w, lo=0.0, hi=1e4))
            com.append(_vector(j, "com_mm", w, 3, bound=1e5))
    if mass and len(mass) != len(joints):
        raise ArmFileError(
            f"{where}: mass_kg and com_mm on {len(mass)} of {len(joints)} joints: give them for "
            "every joint or none"
        )
    parent = arm_tree.parents(joints, where, ArmFileError)
    follows = arm_tree.follows(joints, where, ArmFileError)
    tools = arm_tree.tools(t.get("tool", {}), where, len(joints), ArmFileError, _number, _vector)
    tool_mm, _, tool_mass = tools[0]
    several = len(tools) > 1 or tools[0][1] != len(joints)
    if sum(abs(x) for x in a + d) + max(np.linalg.norm(o) for o, _, _ in tools) < 1.0:
        raise ArmFileError(
            f"{where}: every a_mm, d_mm and the tool's offset_mm are zero: the arm has no length, "
            "its tool point never moves"
        )
    g = _vector(t, "gravity_m_s2", where, 3, default=(0.0, 0.0, -9.81))
    if mass and not 1.0 < np.linalg.norm(g) < 100.0:
        raise ArmFileError(
            f"{where}: gravity_m_s2 has magnitude {np.linalg.norm(g):.3g}: expected about 9.81"
        )
    coupling, cables = _transmission(t.get("transmission"), where, len(joints))
    if follows is not None and (coupling is not None or cables is not None):
        raise ArmFileError(
            f"{where}: a joint that follows others (follows) and a [transmission] together: not "
            "supported; give the coupling in one of them"
        )
    return ArmDescription(
        name=name,
        convention=conv,
        a_mm=tuple(a),
        d_mm=tuple(d),
        alpha_rad=tuple(al),
        theta_rad=tuple(th),
        range_rad=tuple(rng),
        tool_mm=tool_mm,
        mass_kg=tuple(mass) if mass else None,
        com_mm=tuple(com) if com else None,
        tool_mass_kg=tool_mass,
        gravity_m_s2=g,
        coupling=coupling,
        cable_stiffness_nm_per_rad=cables,
        parent=parent,
        follows=follows,
        tools_mm=tuple(o for o, _, _ in tools) if several else None,
        tools_joint=tuple(j for _, j, _ in tools) if several else None,
        tools_mass_kg=tuple(m for _, _, m in tools) if several else None,
        source=where,
    )


def _transmission(table, where: str, N: int) -> tuple[tuple | None, tuple | None]:
    """The optional [transmission] table: (coupling (N, N) rows, cable stiffness (N,)), each None
    when absent (a coupling without cables is rigid; cables without a coupling drive their own
    joint)."""
    if table is None:
        return None, None
    w = f"{where}: [transmission]"
    if not isinstance(table, dict):
        raise ArmFileError(f"{w} must be a table")
    extra = set(table) - {"coupling", "cable_stiffness_nm_per_rad"}
    if extra:
        raise ArmFileError(
            f"{w}: unknown field(s) {', '.join(sorted(extra))} (known: "
            "cable_stiffness_nm_per_rad, coupling)"
        )
    coupling = None
    if "coupling" in table:
        rows = table["coupling"]
        if (
            not isinstance(rows, list)
            or len(rows) != N
            or not all(isinstance(r, list) and len(r) == N for r in rows)
        ):
            raise ArmFileError(
                f"{w}: coupling must be {N} rows of {N} numbers (joint angles = coupling @ motor "
                "angles), one row per joint"
            )
        coupling = tuple(
            _vector({"coupling": r}, "coupling", f"{w}: row {i}", N, bound=1e3)
            for i, r in enumerate(rows, 1)
        )
        cond = np.linalg.cond(np.array(coupling))
        if not cond < 1e10:
            raise ArmFileError(
                f"{w}: coupling is singular (condition number {cond:.3g}): some joint angle is "
                "not set by the motors, or two motors move the joints alike"
            )
    cables = None
    if "cable_stiffness_nm_per_rad" in table:
        v = table["cable_stiffness_nm_per_rad"]
        ok = (
            isinstance(v, list)
            and len(v) == N
            and all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in v)
        )
        if not ok or not all(x > 0 for x in v):  # NaN fails x > 0 too
            raise ArmFileError(
                f"{w}: cable_stiffness_nm_per_rad must be {N} positive numbers (N m / rad per "
                f"motor; inf for a rigid cable), not {v!r}"
            )
        cables = tuple(float(x) for x in v)
    return coupling, cables
