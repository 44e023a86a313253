"""Kinematics of a serial arm: forward kinematics, the parameter Jacobian, gravity torques.

Conventions (docs/formats.md, "Arm descriptions"), for joint i = 1..N with reading q_i:

- ``dh``:  T_i = RotZ(theta_i + q_i) TransZ(d_i) TransX(a_i) RotX(alpha_i) RotY(beta_i)
- ``mdh`` (Craig): T_i = RotX(alpha_i) RotY(beta_i) TransX(a_i) RotZ(theta_i + q_i) TransZ(d_i)

beta_i (Hayati's turn about y) is zero nominally. It is the parameter that describes a small
tilt between two nearly parallel axes, where DH's common normal is ill-defined and the d's of
the parallel joints become one combination (the identification drops the dependent ones).

Frames: the base is frame 0, link frame i follows T_i, the flange is frame N; the measured point
is ``tool_mm`` in the flange frame. Lengths mm, angles rad, masses kg, torques N m.

Parameter errors (``delta``, ``(5 N + 3,)``): per joint (da, dd, dalpha, dtheta, dbeta) added to
the nominal values (dtheta is the joint's zero offset), then the tool point's (dx, dy, dz) in the
flange frame. Names: ``da1 .. dbetaN, tool_x, tool_y, tool_z`` (:func:`param_names`).

Everything is vectorised over postures: q is ``(n, N)``; the only loop runs over the N joints,
chaining their transforms, never over postures.
"""

from __future__ import annotations

import dataclasses
import functools
import re
from collections.abc import Callable

import numpy as np

KINDS = ("da", "dd", "dalpha", "dtheta", "dbeta")
_A, _D, _ALPHA, _THETA, _BETA = range(5)
# each joint's elementary motions in order: (kind, axis index, which parameter)
OPS = {
    "dh": (
        ("rot", 2, _THETA),
        ("trans", 2, _D),
        ("trans", 0, _A),
        ("rot", 0, _ALPHA),
        ("rot", 1, _BETA),
    ),
    "mdh": (
        ("rot", 0, _ALPHA),
        ("rot", 1, _BETA),
        ("trans", 0, _A),
        ("rot", 2, _THETA),
        ("trans", 2, _D),
    ),
}
N_TOOL = 3


@dataclasses.dataclass(frozen=True)
class Chain:
    """A serial arm as the estimators see it: nominal kinematics and, optionally, the masses
    that load its joints under gravity.

    a_mm, d_mm, alpha_rad, theta_rad : (N,) nominal DH (or modified DH) values.
    tool_mm : (3,) the measured point in the flange frame.
    mass_kg : (N,) mass of the link each joint moves, or None (no gravity model).
    com_mm : (N, 3) each link's centre of mass in its own link frame.
    tool_mass_kg : mass carried at the tool point.
    gravity_m_s2 : (3,) gravity in the base frame.
    coupling : (N, N) joint angles = coupling @ motor angles (cables, differentials), or None
        (each motor turns its own joint).

    Treat a chain as immutable, its arrays too: its nominal table is computed once and kept.

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

    def __post_init__(self):
        if self.convention not in OPS:
            raise ValueError(f"convention {self.convention!r}: dh or mdh")

    @property
    def n_joints(self) -> int:
        """The number of joints N."""
        return len(self.a_mm)

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


@functools.cache
def param_names(n_joints: int) -> tuple[str, ...]:
    """Names of the error parameters, in ``delta``'s order."""
    return tuple(f"{k}{i}" for i in range(1, n_joints + 1) for k in KINDS) + (
        "tool_x",
        "tool_y",
        "tool_z",
    )


def param_is_angle(names) -> np.ndarray:
    """For each parameter name, whether it is an angle (rad) rather than a length (mm), (k,)
    bool."""
    return np.array([n.startswith(("dalpha", "dtheta", "dbeta")) for n in names])


def n_params(n_joints: int) -> int:
    """The error parameters of an N-joint chain: 5 per joint (da, dd, dalpha, dtheta, dbeta) and
    the tool's 3."""
    return 5 * n_joints + N_TOOL


def theta_index(joint: int) -> int:
    """Index in ``delta`` of joint ``joint``'s (1-based) zero offset: d(point)/d(q_joint)."""
    return 5 * (joint - 1) + _THETA


class Pose:
    """The chain at n postures.

    link_R, link_o : (n, N + 1, 3, 3) and (n, N + 1, 3) frames 0..N.
    point : (n, 3) the tool point (mm).
    axis : (n, 5 N, 3) base-frame direction of each elementary motion.
    origin : (n, 5 N, 3) where it acts (mm); rotations turn about axis through origin.

    ``axis`` and ``origin`` are made on first use: a residual needs the point alone, a Jacobian
    the motions too.
    """

    def __init__(
        self,
        convention: str,
        link_R: np.ndarray,
        link_o: np.ndarray,
        point: np.ndarray,
        c: np.ndarray,
        s: np.ndarray,
        a: np.ndarray,
        d: np.ndarray,
        alpha: np.ndarray,
    ):
        self.link_R, self.link_o, self.point = link_R, link_o, point
        self._motions_of = (convention, c, s, a, d, alpha)
        self._motions: tuple[np.ndarray, np.ndarray] | None = None

    @property
    def axis(self) -> np.ndarray:
        """(n, 5 N, 3) base-frame direction of each elementary motion."""
        return self._elementary()[0]

    @property
    def origin(self) -> np.ndarray:
        """(n, 5 N, 3) where each elementary motion acts (mm)."""
        return self._elementary()[1]

    def _elementary(self) -> tuple[np.ndarray, np.ndarray]:
        """The elementary motions' axes and origins, in closed form per convention from the link
        frames, (n, 5 N, 3) each."""
        if self._motions is not None:
            return self._motions
        convention, c, s, a, d, alpha = self._motions_of
        link_R, link_o = self.link_R, self.link_o
        n, N = c.shape
        R0, o0, R1, o1 = link_R[:, :-1], link_o[:, :-1], link_R[:, 1:], link_o[:, 1:]
        axis, origin = np.empty((n, N, 5, 3)), np.empty((n, N, 5, 3))
        # dh: RotZ(theta + q), TransZ(d) about frame i-1's z; TransX(a), RotX(alpha) along the
        # turned x. mdh: RotX(alpha), RotY(beta), TransX(a) at frame i-1's origin; RotZ(theta + q),
        # TransZ(d) on frame i's z.
        if convention == "dh":
            x1 = c[..., None] * R0[..., 0] + s[..., None] * R0[..., 1]
            axis[:, :, _THETA] = axis[:, :, _D] = R0[..., 2]
            origin[:, :, _THETA] = origin[:, :, _D] = o0
            axis[:, :, _A] = axis[:, :, _ALPHA] = x1
            origin[:, :, _A] = o0 + d[:, None] * R0[..., 2]
            origin[:, :, _ALPHA] = origin[:, :, _BETA] = o1
            axis[:, :, _BETA] = R1[..., 1]  # RotY keeps y: the turned frame's y is frame i's
        else:
            ca, sa = np.cos(alpha)[:, None], np.sin(alpha)[:, None]
            xm = (
                c[..., None] * R1[..., 0] - s[..., None] * R1[..., 1]
            )  # frame i-1 turned by M: its x
            axis[:, :, _ALPHA] = R0[..., 0]
            axis[:, :, _BETA] = ca * R0[..., 1] + sa * R0[..., 2]
            axis[:, :, _A] = xm
            origin[:, :, _ALPHA] = origin[:, :, _BETA] = origin[:, :, _A] = o0
            axis[:, :, _THETA] = axis[:, :, _D] = R1[..., 2]
            origin[:, :, _THETA] = origin[:, :, _D] = o0 + a[:, None] * xm
        self._motions = (axis.reshape(n, 5 * N, 3), origin.reshape(n, 5 * N, 3))
        return self._motions


def _xy_turn(alpha: np.ndarray, beta: np.ndarray) -> np.ndarray:
    """RotX(alpha) RotY(beta), (N, 3, 3), written out (the product's zeros and ones are exact,
    so this is the product to the bit)."""
    ca, sa, cb, sb = np.cos(alpha), np.sin(alpha), np.cos(beta), np.sin(beta)
    M = np.empty((len(alpha), 3, 3))
    M[:, 0, 0], M[:, 0, 1], M[:, 0, 2] = cb, 0.0, sb
    M[:, 1, 0], M[:, 1, 1], M[:, 1, 2] = sa * sb, ca, -sa * cb
    M[:, 2, 0], M[:, 2, 1], M[:, 2, 2] = -ca * sb, sa, ca * cb
    return M


def pose(chain: Chain, q_rad: np.ndarray, delta: np.ndarray | None = None) -> Pose:
    """The chain at postures ``q_rad`` (n, N) with errors ``delta`` (5 N + 3,) (zero if None).

    Every joint's turn and shift are made at once for all joints and postures; the loop over
    joints only chains them (one product of (n, 3, 3) stacks per joint). The elementary motions'
    axes and origins follow from the link frames, when asked for (:class:`Pose`)."""
    q = np.atleast_2d(np.asarray(q_rad, float))
    N = chain.n_joints
    if q.shape[1] != N:
        raise ValueError(f"postures have {q.shape[1]} joints, the chain {N}")
    delta = np.zeros(n_params(N)) if delta is None else np.asarray(delta, float)
    a, d, alpha, theta, beta = (chain.nominal() + delta[: 5 * N].reshape(N, 5)).T
    n = len(q)
    phi = q + theta  # (n, N)
    c, s = np.cos(phi), np.sin(phi)
    M = _xy_turn(alpha, beta)  # (N, 3, 3)
    dh = chain.convention == "dh"
    # each joint's turn, frame i-1 to frame i: RotZ(phi) M (DH) or M RotZ(phi) (MDH), written out
    # (a stacked product of 3 x 3 matrices costs more than these few broadcasts)
    A = np.empty((n, N, 3, 3))
    c_, s_ = c[..., None], s[..., None]
    if dh:
        A[..., 0, :], A[..., 1, :], A[..., 2, :] = (
            c_ * M[:, 0] - s_ * M[:, 1],
            s_ * M[:, 0] + c_ * M[:, 1],
            M[:, 2],
        )
    else:
        A[..., 0], A[..., 1], A[..., 2] = (
            c_ * M[..., 0] + s_ * M[..., 1],
            c_ * M[..., 1] - s_ * M[..., 0],
            M[..., 2],
        )
    # each joint's shift in frame i-1: DH (a c, a s, d); MDH a along M's x, then d along A's z
    if dh:
        p = np.empty((n, N, 3))
        p[..., 0], p[..., 1], p[..., 2] = a * c, a * s, d
    else:
        p = a[:, None] * M[:, :, 0] + d[:, None] * A[..., 2]
    link_R, link_o = np.empty((n, N + 1, 3, 3)), np.empty((n, N + 1, 3))
    link_R[:, 0], link_o[:, 0] = np.eye(3), 0.0
    for i in range(N):
        R = link_R[:, i]
        link_o[:, i + 1] = link_o[:, i] + (R @ p[:, i, :, None])[..., 0]
        link_R[:, i + 1] = R @ A[:, i]
    tool = chain.tool_mm + delta[5 * N :]
    return Pose(
        chain.convention, link_R, link_o, link_o[:, N] + link_R[:, N] @ tool, c, s, a, d, alpha
    )


def cross(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """u x v over the last axis (np.cross's axis juggling costs more than the arithmetic here)."""
    out = np.empty(np.broadcast_shapes(u.shape, v.shape))
    out[..., 0] = u[..., 1] * v[..., 2] - u[..., 2] * v[..., 1]
    out[..., 1] = u[..., 2] * v[..., 0] - u[..., 0] * v[..., 2]
    out[..., 2] = u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]
    return out


def point(chain: Chain, q_rad: np.ndarray, delta: np.ndarray | None = None) -> np.ndarray:
    """Base-frame position of the tool point, (n, 3) mm."""
    return pose(chain, q_rad, delta).point


def jacobian(
    chain: Chain,
    q_rad: np.ndarray | None = None,
    delta: np.ndarray | None = None,
    P: Pose | None = None,
) -> np.ndarray:
    """d(point) / d(delta), (n, 3, 5 N + 3), analytic.

    A turn about a unit axis w through o moves the point by w x (p - o); a shift along w by w;
    the tool offset moves it through the flange's rotation. ``P``: the pose, when the caller has
    it already. Column ``theta_index(j)`` is also d(point) / d(q_j).
    """
    if P is None:
        assert q_rad is not None, "the postures q_rad, or their pose P"
        P = pose(chain, q_rad, delta)
    N = P.link_R.shape[1] - 1
    n = len(P.point)
    J = np.empty((n, 3, n_params(N)))
    ops = OPS[chain.convention]
    rot = np.zeros(5 * N, bool)
    for kind, _, which in ops:
        rot[which::5] = kind == "rot"
    # every motion's turn made, the shifts' then discarded: one pass instead of a masked copy
    cols = np.where(rot[:, None], cross(P.axis, P.point[:, None] - P.origin), P.axis)
    J[:, :, : 5 * N] = cols.transpose(0, 2, 1)
    J[:, :, 5 * N :] = P.link_R[:, N]
    return J


def gravity_moments(
    chain: Chain,
    q_rad: np.ndarray | None = None,
    delta: np.ndarray | None = None,
    P: Pose | None = None,
) -> np.ndarray:
    """The moment of the weight each joint carries, about a point on its axis, (n, N, 3) N m in
    the base frame: M_i = sum over the links l >= i of (c_l - o_i) x (m_l g), c_l a centre of
    mass (the tool's mass sits at the tool point), o_i the joint's frame origin on its axis."""
    if not chain.has_masses:
        raise ValueError("the chain has no masses: gravity moments need mass_kg and com_mm")
    if P is None:
        assert q_rad is not None, "the postures q_rad, or their pose P"
        P = pose(chain, q_rad, delta)
    N = chain.n_joints
    g = np.asarray(chain.gravity_m_s2, float)
    com = P.link_o[:, 1:] + np.einsum(
        "nlij,lj->nli", P.link_R[:, 1:], np.asarray(chain.com_mm, float)
    )
    weights = np.asarray(chain.mass_kg, float)[None, :, None] * g  # (1, N, 3) N
    f = np.concatenate(
        [
            np.broadcast_to(weights, com.shape),
            (chain.tool_mass_kg * g)[None, None].repeat(len(com), 0),
        ],
        axis=1,
    )
    x = np.concatenate([com, P.point[:, None]], axis=1) / 1000.0  # m
    # moments about the base origin and forces, summed from the tip inward: links l..N and the tool
    moment = np.cumsum(cross(x, f)[:, ::-1], axis=1)[:, ::-1]
    force = np.cumsum(f[:, ::-1], axis=1)[:, ::-1]
    o = P.origin[:, _THETA::5] / 1000.0
    return moment[:, :N] - cross(o, force[:, :N])  # about o_i: M_0 - o_i x F


def joint_axes(P: Pose) -> tuple[np.ndarray, np.ndarray]:
    """Each joint's axis (n, N, 3) and a point on it (n, N, 3) mm."""
    return P.axis[:, _THETA::5], P.origin[:, _THETA::5]


def gravity_torques(
    chain: Chain,
    q_rad: np.ndarray | None = None,
    delta: np.ndarray | None = None,
    P: Pose | None = None,
) -> np.ndarray:
    """The torque gravity puts on each joint (the generalized gravity force), (n, N) N m.

    tau_i = w_i . M_i, w_i joint i's axis and M_i the moment of the weight it carries
    (:func:`gravity_moments`). Positive tau_i turns joint i positively; a joint of compliance c
    deflects by c tau_i.
    """
    if P is None:
        assert q_rad is not None, "the postures q_rad, or their pose P"
        P = pose(chain, q_rad, delta)
    return np.einsum("nij,nij->ni", P.axis[:, _THETA::5], gravity_moments(chain, P=P))


def parameter_scales(names) -> np.ndarray:
    """Typical sizes to make columns comparable: 0.1 mm for lengths, 1 mrad for angles, 100 urad
    for a joint's angle error terms,
    10 urad / N m for a joint's compliance (a robot's gearbox: 1e5 N m / rad), 1 urad / N m for a
    bearing's tilt."""
    return np.array(_scales(tuple(names)))


@functools.lru_cache(maxsize=64)
def _scales(names: tuple) -> tuple:
    """The typical sizes of ``names``' errors, cached: a problem asks at every basis and bound."""
    return tuple(
        1e-3
        if n.startswith(("dalpha", "dtheta", "dbeta", "tracker_r", "base_r", "cone_r"))
        else 1e-4
        if n.startswith("angle_")
        else 1e-5
        if n.startswith(("compliance", "cable_compliance"))
        else 1e-6
        if n.startswith("tilt_compliance")
        else 0.1
        for n in names
    )


def geometric_columns(names) -> np.ndarray:
    """(n,) bool: the parameters that are not a compliance. The largest of their columns sets an
    identifiable basis's tolerance: a compliance's column grows with the arm's torques (a 200 kg
    arm's, 25 times an angle's), and would otherwise lift the tolerance over columns of the
    geometry that the data do determine."""
    return np.array(
        [not n.startswith(("compliance", "tilt_compliance", "cable_compliance")) for n in names],
        bool,
    )


class ArmParameters:
    """What an arm's identification problems share beyond the protocol's own data: the typical
    sizes of their parameters and the columns that set the rank tolerance, both by name."""

    @property
    def names(self) -> tuple[str, ...]:
        """Every parameter's name, in column order (each problem says its own)."""
        raise NotImplementedError

    def scales(self) -> np.ndarray:
        """(n,) typical sizes of the parameters' errors (:func:`parameter_scales`)."""
        return parameter_scales(self.names)

    def reference(self) -> np.ndarray:
        """(n,) bool: the columns that set the rank tolerance (:func:`geometric_columns`)."""
        return geometric_columns(self.names)


def parallel_axes_note(parallel: list[tuple[int, int]]) -> Callable[[str, list[str]], str]:
    """A note for :func:`~calibench.estimators.identification.basis.identifiable_basis`: ``'
    (parallel axes i-j)'`` when a dropped d or theta depends on a neighbour across one of the
    consecutive parallel joint pairs ``parallel``."""

    def note(name: str, partners: list[str]) -> str:
        m = re.fullmatch(r"(dd|dtheta|da|dalpha)(\d+)", name)
        if not m:
            return ""
        j = int(m.group(2))
        for i, k in parallel:
            if j in (i, k) or j == k + 1:
                for p in partners:
                    mp = re.fullmatch(r"(dd|dtheta|da|dalpha|dbeta)(\d+)", p)
                    if mp and int(mp.group(2)) in (i, k, k + 1) and int(mp.group(2)) != j:
                        return f" (parallel axes {i}-{k})"
        return ""

    return note
