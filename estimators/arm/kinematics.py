"""Kinematics of an arm, serial or branched: forward kinematics, the parameter Jacobian, gravity
torques.

Conventions (docs/formats.md, "Arm descriptions"), for joint i = 1..N with reading q_i:

- ``dh``:  T_i = RotZ(theta_i + q_i) TransZ(d_i) TransX(a_i) RotX(alpha_i) RotY(beta_i)
- ``mdh`` (Craig): T_i = RotX(alpha_i) RotY(beta_i) TransX(a_i) RotZ(theta_i + q_i) TransZ(d_i)

beta_i (Hayati's turn about y) is zero nominally. It is the parameter that describes a small
tilt between two nearly parallel axes, where DH's common normal is ill-defined and the d's of
the parallel joints become one combination (the identification drops the dependent ones).

Frames: the base is frame 0, link frame i follows T_i from its parent's frame (the previous
joint's on a serial arm; ``Chain.parent`` on a branched one: a torso carrying two arms), the
flange is frame N; the measured point is ``tool_mm`` in the flange frame, or each of several
tools' in its own joint's frame (``Chain.tools_mm``, ``Chain.tools_joint``). A row measures one
tool (``tool``, 0-based; the first if None): its point moves with the joints on its path from
the base only. A joint that follows others (``Chain.follows``: its angle a q_i + b q_j, no
encoder of its own) takes its angle from their readings. Lengths mm, angles rad, masses kg,
torques N m.

Parameter errors (``delta``, ``(5 N + 3 T,)``): per joint (da, dd, dalpha, dtheta, dbeta) added
to the nominal values (dtheta is the joint's zero offset), then each tool point's (dx, dy, dz) in
its frame. Names: ``da1 .. dbetaN, tool_x, tool_y, tool_z`` (then ``tool2_x`` ... for a second
tool; :func:`param_names`).

Everything is vectorised over postures: q is ``(n, N)``; the only loops run over the N joints
(chaining their transforms) and the T tools, never over postures.
"""

from __future__ import annotations

import numpy as np

from calibench.estimators.arm.chain import (  # noqa: F401  (re-exported: their old home)
    I_A,
    I_ALPHA,
    I_BETA,
    I_D,
    I_THETA,
    KINDS,
    N_TOOL,
    OPS,
    Chain,
    chain_names,
    in_readings,
    joint_angles,
    n_params,
    param_is_angle,
    param_names,
    theta_index,
)
from calibench.estimators.arm.parameters import (  # noqa: F401  (re-exported: their old home)
    ArmParameters,
    geometric_columns,
    parallel_axes_note,
    parameter_scales,
)


class Pose:
    """The chain at n postures.

    Rc, oc : (N + 1, 3, 3, n) and (N + 1, 3, n) frames 0..N, component-major (each component
        of a frame one run over the postures, as :func:`pose` chains them).
    link_R, link_o : (n, N + 1, 3, 3) and (n, N + 1, 3) the same, posture-major.
    point : (n, 3) each row's tool point (mm).
    tools : (n, T, 3) every tool's point (mm).
    tool : (n,) int each row's tool (0-based), or None: the first.
    axis : (n, 5 N, 3) base-frame direction of each elementary motion.
    origin : (n, 5 N, 3) where it acts (mm); rotations turn about axis through origin.

    ``link_R``, ``link_o``, ``axis`` and ``origin`` are made on first use: a residual needs the
    point alone, a Jacobian the motions too (from ``Rc`` and ``oc``).
    """

    def __init__(
        self,
        convention: str,
        Rc: np.ndarray,
        oc: np.ndarray,
        point: np.ndarray,
        c: np.ndarray,
        s: np.ndarray,
        a: np.ndarray,
        d: np.ndarray,
        alpha: np.ndarray,
        frames: np.ndarray | None = None,
        tools: np.ndarray | None = None,
        tool: np.ndarray | None = None,
    ):
        self.Rc, self.oc, self.point = Rc, oc, point
        self._links: tuple[np.ndarray, np.ndarray] | None = None
        self.tools = point[:, None] if tools is None else tools
        self.tool = tool
        self._motions_of = (convention, c, s, a, d, alpha, frames)
        self._motions: tuple[np.ndarray, np.ndarray] | None = None
        self._kinds: list[tuple[np.ndarray, np.ndarray]] | None = None

    @property
    def link_R(self) -> np.ndarray:
        """(n, N + 1, 3, 3) the link frames' rotations, posture-major."""
        return self._posture_major()[0]

    @property
    def link_o(self) -> np.ndarray:
        """(n, N + 1, 3) the link frames' origins (mm), posture-major."""
        return self._posture_major()[1]

    def _posture_major(self) -> tuple[np.ndarray, np.ndarray]:
        """``Rc`` and ``oc`` laid out posture-major, once (a copy of 10 MB on 15,000 postures,
        which a residual does not need)."""
        if self._links is None:
            self._links = (
                np.ascontiguousarray(self.Rc.transpose(3, 0, 1, 2)),
                np.ascontiguousarray(self.oc.transpose(2, 0, 1)),
            )
        return self._links

    @property
    def axis(self) -> np.ndarray:
        """(n, 5 N, 3) base-frame direction of each elementary motion."""
        return self._elementary()[0]

    @property
    def origin(self) -> np.ndarray:
        """(n, 5 N, 3) where each elementary motion acts (mm)."""
        return self._elementary()[1]

    def _elementary(self) -> tuple[np.ndarray, np.ndarray]:
        """The elementary motions' axes and origins, (n, 5 N, 3) each, interleaved per joint
        from :meth:`motions`."""
        if self._motions is None:
            kinds = self.motions()
            n, N = self.point.shape[0], self.Rc.shape[0] - 1
            # (5, N, 3, n) to (n, N, 5, 3): posture, joint, kind, component
            axis = np.stack([w for w, _ in kinds]).transpose(3, 1, 0, 2).reshape(n, 5 * N, 3)
            origin = np.stack([o for _, o in kinds]).transpose(3, 1, 0, 2).reshape(n, 5 * N, 3)
            self._motions = (axis, origin)
        return self._motions

    def motions(self) -> list[tuple[np.ndarray, np.ndarray]]:
        """Each kind of elementary motion's (axis, origin), (N, 3, n) each (joint, component,
        postures), in the order of a joint's parameters (``I_A`` .. ``I_BETA``), in closed form
        per convention from the link frames. Kept: the Jacobian reads them kind by kind,
        :attr:`axis` interleaves them."""
        if self._kinds is not None:
            return self._kinds
        convention, c, s, a, d, alpha, frames = self._motions_of
        Rc, oc = self.Rc, self.oc
        # frame i-1 is joint i's parent's: the previous joint's on a serial arm
        R0, o0 = (Rc[:-1], oc[:-1]) if frames is None else (Rc[frames], oc[frames])
        R1, o1 = Rc[1:], oc[1:]  # (N, 3, 3, n), (N, 3, n)
        cT, sT = c.T[:, None], s.T[:, None]  # (N, 1, n)
        out: list = [None] * 5
        # dh: RotZ(theta + q), TransZ(d) about frame i-1's z; TransX(a), RotX(alpha) along the
        # turned x. mdh: RotX(alpha), RotY(beta), TransX(a) at frame i-1's origin; RotZ(theta + q),
        # TransZ(d) on frame i's z.
        if convention == "dh":
            x1 = cT * R0[:, :, 0] + sT * R0[:, :, 1]
            out[I_THETA] = out[I_D] = (R0[:, :, 2], o0)
            out[I_A] = (x1, o0 + d[:, None, None] * R0[:, :, 2])
            out[I_ALPHA] = (x1, o1)
            out[I_BETA] = (R1[:, :, 1], o1)  # RotY keeps y: the turned frame's y is frame i's
        else:
            ca, sa = np.cos(alpha)[:, None, None], np.sin(alpha)[:, None, None]
            xm = cT * R1[:, :, 0] - sT * R1[:, :, 1]  # frame i-1 turned: its x
            out[I_ALPHA] = (R0[:, :, 0], o0)
            out[I_BETA] = (ca * R0[:, :, 1] + sa * R0[:, :, 2], o0)
            out[I_A] = (xm, o0)
            out[I_THETA] = out[I_D] = (R1[:, :, 2], o0 + a[:, None, None] * xm)
        self._kinds = out
        return out


def _xy_turn(alpha: np.ndarray, beta: np.ndarray) -> np.ndarray:
    """RotX(alpha) RotY(beta), (N, 3, 3), written out (the product's zeros and ones are exact,
    so this is the product to the bit)."""
    ca, sa, cb, sb = np.cos(alpha), np.sin(alpha), np.cos(beta), np.sin(beta)
    M = np.empty((len(alpha), 3, 3))
    M[:, 0, 0], M[:, 0, 1], M[:, 0, 2] = cb, 0.0, sb
    M[:, 1, 0], M[:, 1, 1], M[:, 1, 2] = sa * sb, ca, -sa * cb
    M[:, 2, 0], M[:, 2, 1], M[:, 2, 2] = -ca * sb, sa, ca * cb
    return M


def _tool_rows(chain: Chain, tool, n: int) -> np.ndarray | None:
    """Each row's tool (n,) int checked against the chain's tools, or None: every row the
    first."""
    if tool is None:
        return None
    tool = np.asarray(tool, int)
    if tool.shape != (n,):
        raise ValueError(f"tool has shape {tool.shape}; one per posture, ({n},)")
    if len(tool) and (tool.min() < 0 or tool.max() >= chain.n_tools):
        raise ValueError(f"a row measures tool {tool.max() + 1}; the chain has {chain.n_tools}")
    return tool


def pose(chain: Chain, q_rad: np.ndarray, delta: np.ndarray | None = None, tool=None) -> Pose:
    """The chain at readings ``q_rad`` (n, N) with errors ``delta`` (5 N + 3 T,) (zero if None),
    each row's point that of its ``tool`` (n,) (0-based; the first if None).

    Every joint's turn and shift are made at once for all joints and postures; the loop over
    joints only chains them, each from its parent's frame, an entry at a time over all the
    postures (a matrix product's sums written out: not a BLAS call per 3 x 3 product, whose
    fused multiply-adds round differently, by an ulp). The elementary motions' axes and
    origins follow from the link frames, when asked for (:class:`Pose`)."""
    q = np.atleast_2d(np.asarray(q_rad, float))
    N, T = chain.n_joints, chain.n_tools
    if q.shape[1] != N:
        raise ValueError(f"postures have {q.shape[1]} joints, the chain {N}")
    tool = _tool_rows(chain, tool, len(q))
    delta = np.zeros(n_params(N, T)) if delta is None else np.asarray(delta, float)
    a, d, alpha, theta, beta = (chain.nominal() + delta[: 5 * N].reshape(N, 5)).T
    n = len(q)
    phi = joint_angles(chain, q) + theta  # (n, N)
    c, s = np.cos(phi), np.sin(phi)
    M = _xy_turn(alpha, beta)  # (N, 3, 3)
    dh = chain.convention == "dh"
    # each joint's turn, frame i-1 to frame i: RotZ(phi) M (DH) or M RotZ(phi) (MDH), written out
    # entry by entry, each entry a run over the postures (N, 3, 3, n): numpy's loops are long
    # where a stack of 3 x 3 matrices gives them 3 elements, or a BLAS call each
    cT, sT = c.T, s.T  # (N, n)
    A = np.empty((N, 3, 3, n))
    for k in range(3):
        if dh:  # column k
            m = M[:, :, k, None]  # (N, 3, 1)
            A[:, 0, k], A[:, 1, k] = cT * m[:, 0] - sT * m[:, 1], sT * m[:, 0] + cT * m[:, 1]
            A[:, 2, k] = m[:, 2]
        else:  # row k
            m = M[:, k, :, None]
            A[:, k, 0], A[:, k, 1] = cT * m[:, 0] + sT * m[:, 1], cT * m[:, 1] - sT * m[:, 0]
            A[:, k, 2] = m[:, 2]
    # each joint's shift in frame i-1, (N, 3, n): DH (a c, a s, d); MDH a along M's x, then d
    # along A's z
    if dh:
        p = np.empty((N, 3, n))
        p[:, 0], p[:, 1], p[:, 2] = a[:, None] * cT, a[:, None] * sT, d[:, None]
    else:
        p = a[:, None, None] * M[:, :, 0, None] + d[:, None, None] * A[:, :, 2]
    # chained component by component (R_i = R_parent A_i, o_i = o_parent + R_parent p_i), then
    # laid out posture-major
    Rc, oc = np.empty((N + 1, 3, 3, n)), np.empty((N + 1, 3, n))
    Rc[0], oc[0] = np.eye(3)[:, :, None], 0.0
    frames = chain.frames
    for i in range(N):
        R, Ai, pi = Rc[frames[i]], A[i], p[i]
        for r in range(3):
            oc[i + 1, r] = oc[frames[i], r] + (R[r, 0] * pi[0] + R[r, 1] * pi[1] + R[r, 2] * pi[2])
            Rc[i + 1, r] = R[r, 0] * Ai[0] + R[r, 1] * Ai[1] + R[r, 2] * Ai[2]
    offsets = chain.tool_offsets() + delta[5 * N :].reshape(T, 3)
    at = chain.tool_frames
    # each tool's frame posture-major for its product: its own stack alone, not every frame's
    tools = np.stack(
        [oc[f].T + np.ascontiguousarray(Rc[f].transpose(2, 0, 1)) @ o for f, o in zip(at, offsets)],
        axis=1,
    )
    point = tools[:, 0] if tool is None else tools[np.arange(n), tool]
    tree = None if chain.parent is None else frames
    return Pose(chain.convention, Rc, oc, point, c, s, a, d, alpha, tree, tools, tool)


def cross(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """u x v over the last axis (np.cross's axis juggling costs more than the arithmetic here)."""
    out = np.empty(np.broadcast_shapes(u.shape, v.shape))
    out[..., 0] = u[..., 1] * v[..., 2] - u[..., 2] * v[..., 1]
    out[..., 1] = u[..., 2] * v[..., 0] - u[..., 0] * v[..., 2]
    out[..., 2] = u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]
    return out


def point(
    chain: Chain, q_rad: np.ndarray, delta: np.ndarray | None = None, tool=None
) -> np.ndarray:
    """Base-frame position of each row's tool point, (n, 3) mm."""
    return pose(chain, q_rad, delta, tool).point


def carried_by(chain: Chain, P: Pose) -> np.ndarray | None:
    """(n, N) bool: the joints whose turn moves each row's point (those on its tool's path), or
    None where every joint moves every row's (a serial arm)."""
    on = chain.on_path
    if on.all():
        return None
    return on[0 if P.tool is None else P.tool]


def jacobian(
    chain: Chain,
    q_rad: np.ndarray | None = None,
    delta: np.ndarray | None = None,
    P: Pose | None = None,
    tool=None,
) -> np.ndarray:
    """d(point) / d(delta), (n, 3, 5 N + 3 T), analytic: each row's point, that of its ``tool``
    (n,) (0-based; the first if None; ``P``'s own where given).

    A turn about a unit axis w through o moves the point by w x (p - o); a shift along w by w;
    the tool offset moves it through its link's rotation. A joint off a row's tool path (the other
    arm of a torso) moves it not at all. ``P``: the pose, when the caller has it already. Column
    ``theta_index(j)`` is also d(point) / d(q_j), q_j joint j's angle (a follower's too:
    :func:`in_readings` turns them into the readings').
    """
    if P is None:
        assert q_rad is not None, "the postures q_rad, or their pose P"
        P = pose(chain, q_rad, delta, tool)
    N = P.Rc.shape[0] - 1
    n, T = len(P.point), chain.n_tools
    J = np.empty((n, 3, n_params(N, T)))
    on = carried_by(chain, P)
    # kind by kind into its columns (every joint's k-th, J[:, :, k::5]): a turn's w x (p - o)
    # for the turns alone, a shift's w as it is
    point = P.point.T  # (3, n)
    for kind, _, which in OPS[chain.convention]:
        w, o = P.motions()[which]  # (N, 3, n)
        cols = J[:, :, which : 5 * N : 5].transpose(2, 1, 0)  # (N, 3, n), a view
        if kind == "rot":
            v = point - o
            cols[:, 0] = w[:, 1] * v[:, 2] - w[:, 2] * v[:, 1]
            cols[:, 1] = w[:, 2] * v[:, 0] - w[:, 0] * v[:, 2]
            cols[:, 2] = w[:, 0] * v[:, 1] - w[:, 1] * v[:, 0]
        else:
            cols[:] = w
        if on is not None:
            cols *= on.T[:, None, :]
    at = chain.tool_frames
    if T == 1:
        J[:, :, 5 * N :].transpose(1, 2, 0)[:] = P.Rc[at[0]]  # (3, 3, n) views
        return J
    J[:, :, 5 * N :] = 0.0
    rows = np.zeros(n, int) if P.tool is None else P.tool
    for k in range(T):
        m = rows == k
        J[m, :, 5 * N + 3 * k : 5 * N + 3 * k + 3] = P.link_R[m, at[k]]
    return J


def _carried_weight(chain: Chain, P: Pose) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each joint's carried weight: the moment about the base origin (n, N, 3) N m and the force
    (n, N, 3) N of the links and tools it carries (:attr:`Chain.carries`), and each link's own
    moment (n, N, 3) about the base origin. Summed from the tips inward, each joint's into its
    parent's (on a serial arm the running sum from the tool to the base)."""
    N = chain.n_joints
    g = np.asarray(chain.gravity_m_s2, float)
    com = P.link_o[:, 1:] + np.einsum(
        "nlij,lj->nli", P.link_R[:, 1:], np.asarray(chain.com_mm, float)
    )
    weights = np.asarray(chain.mass_kg, float)[None, :, None] * g  # (1, N, 3) N
    f = np.concatenate(
        [
            np.broadcast_to(weights, com.shape),
            np.broadcast_to((chain.tool_masses()[:, None] * g)[None], P.tools.shape),
        ],
        axis=1,
    )
    x = np.concatenate([com, P.tools], axis=1) / 1000.0  # m
    own = cross(x, f)
    moment, force = own[:, :N].copy(), f[:, :N].copy()
    for k, at in enumerate(chain.tool_frames):  # each tool into the link that carries it
        moment[:, at - 1] += own[:, N + k]
        force[:, at - 1] += f[:, N + k]
    frames = chain.frames
    for i in range(N - 1, -1, -1):  # a child comes after its parent: tips first
        if frames[i] > 0:
            moment[:, frames[i] - 1] += moment[:, i]
            force[:, frames[i] - 1] += force[:, i]
    return moment, force, own[:, :N]


def gravity_moments(
    chain: Chain,
    q_rad: np.ndarray | None = None,
    delta: np.ndarray | None = None,
    P: Pose | None = None,
) -> np.ndarray:
    """The moment of the weight each joint carries, about a point on its axis, (n, N, 3) N m in
    the base frame: M_i = sum over the links l joint i carries of (c_l - o_i) x (m_l g), c_l a
    centre of mass (each tool's mass at its point), o_i the joint's frame origin on its axis. A
    joint a torso's two arms hang from carries both."""
    if not chain.has_masses:
        raise ValueError("the chain has no masses: gravity moments need mass_kg and com_mm")
    if P is None:
        assert q_rad is not None, "the postures q_rad, or their pose P"
        P = pose(chain, q_rad, delta)
    moment, force, _ = _carried_weight(chain, P)
    o = P.origin[:, I_THETA::5] / 1000.0
    return moment - cross(o, force)  # about o_i: M_0 - o_i x F


def link_middles(P: Pose, links) -> tuple[np.ndarray, np.ndarray]:
    """Where links ``links`` (1-based joints) bend across: each one's middle (n, k, 3) mm, halfway
    from its joint's axis point to its link frame's origin, and its direction (n, k, 3) there
    (unit; the link's length must not be zero)."""
    j = np.asarray(links, int) - 1
    start, end = P.origin[:, I_THETA::5][:, j], P.link_o[:, 1:][:, j]
    u = end - start
    return start + u / 2, u / np.linalg.norm(u, axis=2, keepdims=True)


def flex_moments(chain: Chain, P: Pose, links) -> np.ndarray:
    """The moment across each of links ``links`` (1-based joints) at its middle, (n, k, 3) N m:
    the weight it carries beyond its own (the links and tools after it; its own mass sits in its
    inner half) about the middle (:func:`link_middles`), less its part along the link (which
    twists the link, not bends it)."""
    if not chain.has_masses:
        raise ValueError("the chain has no masses: gravity moments need mass_kg and com_mm")
    moment, force, own = _carried_weight(chain, P)
    j = np.asarray(links, int) - 1
    g = np.asarray(chain.gravity_m_s2, float)
    beyond = force[:, j] - np.asarray(chain.mass_kg, float)[j][:, None] * g
    h, u = link_middles(P, links)
    M = moment[:, j] - own[:, j] - cross(h / 1000.0, beyond)
    return M - np.sum(M * u, axis=2, keepdims=True) * u


def joint_axes(P: Pose) -> tuple[np.ndarray, np.ndarray]:
    """Each joint's axis (n, N, 3) and a point on it (n, N, 3) mm."""
    return P.axis[:, I_THETA::5], P.origin[:, I_THETA::5]


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
    return np.einsum("nij,nij->ni", P.axis[:, I_THETA::5], gravity_moments(chain, P=P))
