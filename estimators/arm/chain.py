"""An arm as the estimators see it (:class:`Chain`: a serial arm or a tree of joints, its tools,
its followers) and the layout of its error parameters (``delta``: 5 per joint, 3 per tool).
Its kinematics are :mod:`calibench.estimators.arm.kinematics`'s."""

from __future__ import annotations

import dataclasses
import functools

import numpy as np

KINDS = ("da", "dd", "dalpha", "dtheta", "dbeta")
# each joint's parameters in ``delta``: (da, dd, dalpha, dtheta, dbeta), these indices of its five
I_A, I_D, I_ALPHA, I_THETA, I_BETA = range(5)
# each joint's elementary motions in order: (kind, axis index, which parameter)
OPS = {
    "dh": (
        ("rot", 2, I_THETA),
        ("trans", 2, I_D),
        ("trans", 0, I_A),
        ("rot", 0, I_ALPHA),
        ("rot", 1, I_BETA),
    ),
    "mdh": (
        ("rot", 0, I_ALPHA),
        ("rot", 1, I_BETA),
        ("trans", 0, I_A),
        ("rot", 2, I_THETA),
        ("trans", 2, I_D),
    ),
}
N_TOOL = 3


@dataclasses.dataclass(frozen=True)
class Chain:
    """An arm as the estimators see it: nominal kinematics and, optionally, the masses that load
    its joints under gravity.

    a_mm, d_mm, alpha_rad, theta_rad : (N,) nominal DH (or modified DH) values.
    tool_mm : (3,) the measured point in the flange frame (the first tool's, where several).
    mass_kg : (N,) mass of the link each joint moves, or None (no gravity model).
    com_mm : (N, 3) each link's centre of mass in its own link frame.
    tool_mass_kg : mass carried at the tool point (the first tool's).
    gravity_m_s2 : (3,) gravity in the base frame.
    coupling : (N, N) joint angles = coupling @ motor angles (cables, differentials), or None
        (each motor turns its own joint).
    parent : (N,) each joint's parent, 0 the base and k joint k (1-based, before it), or None:
        serial, each joint mounted after the previous one.
    follows : (N, N) joint angles = follows @ readings, or None. A joint without an encoder of
        its own, coupled to others (a torso joint at a q_i + b q_j), has that row and a zero
        column (its reading is ignored); every other joint its unit row and column.
    tools_mm : (T, 3) every tool's point in its joint's link frame, or None: one, ``tool_mm`` in
        the flange frame.
    tools_joint : (T,) the joint (1-based) whose link carries each tool.
    tools_mass_kg : (T,) each tool's mass.

    Treat a chain as immutable, its arrays too: its nominal table and its tree are computed once
    and kept.

    The fields carry the names and units of an arm description's (ARM.toml): the scenarios make
    a chain from a description field by field by name (``scenarios.arm_cmm.arms.chain_of``), so
    a field added here must be one of the description's too.
    """

    convention: str
    a_mm: np.ndarray
    d_mm: np.ndarray
    alpha_rad: np.ndarray
    theta_rad: np.ndarray
    tool_mm: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(3))
    mass_kg: np.ndarray | None = None
    com_mm: np.ndarray | None = None
    tool_mass_kg: float = 0.0
    gravity_m_s2: np.ndarray = dataclasses.field(
        default_factory=lambda: np.array([0.0, 0.0, -9.81])
    )
    coupling: np.ndarray | None = None
    parent: np.ndarray | None = None
    follows: np.ndarray | None = None
    tools_mm: np.ndarray | None = None
    tools_joint: np.ndarray | None = None
    tools_mass_kg: np.ndarray | None = None

    def __post_init__(self):
        if self.convention not in OPS:
            raise ValueError(f"convention {self.convention!r}: dh or mdh")

    @property
    def n_joints(self) -> int:
        """The number of joints N."""
        return len(self.a_mm)

    @property
    def n_tools(self) -> int:
        """The number of tools T (measured points)."""
        return 1 if self.tools_mm is None else len(self.tools_mm)

    @property
    def has_masses(self) -> bool:
        """Whether every link has a mass and a centre of mass (gravity torques need them)."""
        return self.mass_kg is not None

    def nominal(self) -> np.ndarray:
        """(N, 5) nominal a, d, alpha, theta, beta per joint."""
        return self._nominal.copy()

    @functools.cached_property
    def _nominal(self) -> np.ndarray:
        return np.stack(
            [self.a_mm, self.d_mm, self.alpha_rad, self.theta_rad, np.zeros(self.n_joints)], axis=1
        )

    @functools.cached_property
    def frames(self) -> np.ndarray:
        """(N,) int: the frame each joint turns from, its parent's (0 the base)."""
        if self.parent is None:
            return np.arange(self.n_joints)
        return np.asarray(self.parent, float).astype(int)

    @functools.cached_property
    def tool_frames(self) -> np.ndarray:
        """(T,) int: the link frame (1..N) that carries each tool."""
        if self.tools_joint is None:
            return np.array([self.n_joints])
        return np.asarray(self.tools_joint, float).astype(int)

    def tool_offsets(self) -> np.ndarray:
        """(T, 3) each tool's nominal point in its link frame, mm."""
        if self.tools_mm is None:
            return np.asarray(self.tool_mm, float)[None]
        return np.asarray(self.tools_mm, float)

    def tool_masses(self) -> np.ndarray:
        """(T,) each tool's mass, kg."""
        if self.tools_mass_kg is None:
            return np.array([float(self.tool_mass_kg)])
        return np.asarray(self.tools_mass_kg, float)

    @functools.cached_property
    def carries(self) -> np.ndarray:
        """(N, N + T) bool: which links (then tools) each joint carries, its own link included:
        what its turn moves and what its gravity torque weighs."""
        N, frames = self.n_joints, self.frames
        out = np.zeros((N, N + self.n_tools), bool)
        out[np.arange(N), np.arange(N)] = True
        out[self.tool_frames - 1, N + np.arange(self.n_tools)] = True
        for i in range(N - 1, -1, -1):  # a parent comes before its children
            if frames[i] > 0:
                out[frames[i] - 1] |= out[i]
        return out

    @functools.cached_property
    def on_path(self) -> np.ndarray:
        """(T, N) bool: the joints on each tool's path from the base."""
        return self.carries[:, self.n_joints :].T.copy()

    @functools.cached_property
    def followers(self) -> tuple[int, ...]:
        """The joints (1-based) that follow others, without an encoder of their own."""
        if self.follows is None:
            return ()
        F = np.asarray(self.follows, float)
        return tuple(int(j) + 1 for j in range(self.n_joints) if F[j, j] == 0.0)


@functools.cache
def param_names(n_joints: int, n_tools: int = 1) -> tuple[str, ...]:
    """Names of the error parameters, in ``delta``'s order."""
    tools = tuple(f"tool{'' if k == 0 else k + 1}_{axis}" for k in range(n_tools) for axis in "xyz")
    return tuple(f"{k}{i}" for i in range(1, n_joints + 1) for k in KINDS) + tools


def chain_names(chain: Chain) -> tuple[str, ...]:
    """The chain's error parameters' names (:func:`param_names` of its joints and tools)."""
    return param_names(chain.n_joints, chain.n_tools)


def param_is_angle(names) -> np.ndarray:
    """For each parameter name, whether it is an angle (rad) rather than a length (mm), (k,)
    bool."""
    return np.array([n.startswith(("dalpha", "dtheta", "dbeta")) for n in names])


def n_params(n_joints: int, n_tools: int = 1) -> int:
    """The error parameters of an N-joint chain with T tools: 5 per joint (da, dd, dalpha, dtheta,
    dbeta) and each tool's 3."""
    return 5 * n_joints + N_TOOL * n_tools


def joint_angles(chain: Chain, q_rad: np.ndarray) -> np.ndarray:
    """The joints' angles (n, N) at readings ``q_rad`` (n, N): the readings, each follower's
    column made from the joints it follows (what it read, even NaN, ignored)."""
    if not chain.followers:
        return q_rad
    F = np.asarray(chain.follows, float)
    out = np.array(q_rad, float)
    for f in chain.followers:
        row = F[f - 1]
        out[:, f - 1] = sum(row[k] * q_rad[:, k] for k in np.flatnonzero(row))
    return out


def in_readings(chain: Chain, per_joint: np.ndarray) -> np.ndarray:
    """What acts on the joints' angles (the last axis, N: a turn's columns (n, 3, N), torques
    (n, N)) seen on the readings: joint i's reading turns the joints that follow it too (a q_i),
    so its column gathers theirs, and a follower's is zero (it has no reading). The same array
    on an arm without followers."""
    if not chain.followers:
        return per_joint
    return per_joint @ np.asarray(chain.follows, float)


def theta_index(joint: int) -> int:
    """Index in ``delta`` of joint ``joint``'s (1-based) zero offset: d(point)/d(q_joint)."""
    return 5 * (joint - 1) + I_THETA
