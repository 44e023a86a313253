"""The ``arm-cmm`` scene's MJCF: an arm description (:mod:`calibench.scenes.arm_cmm`) with
as-built parameter values, as MJCF text (:func:`build_mjcf`), or compiled fast from a cached spec
(:func:`as_built_model`), or written into a compiled model in place (:func:`write_as_built`).

World frame = the arm's base frame, z up, metres. Joint i is body ``joint{i}``: the hinge frame
(its z axis is the joint's axis, the joint's zero offset included), a hinge ``q{i}``, the link's
mass and centre of mass; its child body ``link{i}`` is link frame i of the convention (dh or
mdh). The tool point is site ``probe`` in the flange frame (body ``link{N}``), the tool's mass
in body ``tool``. Each hinge may carry a spring (its stiffness, N m / rad) whose reference the
simulation sets to the motor's angle: the link then settles where the spring holds gravity.
Contacts are off: the arm is a measuring instrument.
"""

from __future__ import annotations

import dataclasses
import functools
import threading

import numpy as np

from calibench.scenes.arm_cmm import ArmDescription


def quoteattr(text: str) -> str:
    """``text`` as an XML attribute's quoted value, as ``xml.sax.saxutils.quoteattr`` writes it
    (character for character: a test compares them); written out because importing saxutils
    imports urllib.request, ssl and http.client, 27 ms of every study worker's start."""
    for raw, entity in (("&", "&amp;"), (">", "&gt;"), ("<", "&lt;")):
        text = text.replace(raw, entity)
    for raw, entity in (("\n", "&#10;"), ("\r", "&#13;"), ("\t", "&#9;")):
        text = text.replace(raw, entity)
    if '"' not in text:
        return f'"{text}"'
    if "'" not in text:
        return f"'{text}'"
    return '"{}"'.format(text.replace('"', "&quot;"))


def _rot(axis: str, angle: np.ndarray) -> np.ndarray:
    """Turns about a coordinate axis by angles (N,), (N, 3, 3), written out."""
    angle = np.asarray(angle, float)
    c, s = np.cos(angle), np.sin(angle)
    i, j = {"x": (1, 2), "y": (2, 0), "z": (0, 1)}[axis]
    R = np.zeros((len(angle), 3, 3))
    R[:, 3 - i - j, 3 - i - j] = 1.0
    R[:, i, i], R[:, j, j], R[:, i, j], R[:, j, i] = c, c, -s, s
    return R


def _quat(axis: str, angle: np.ndarray) -> np.ndarray:
    """The same turns as unit quaternions (N, 4), w x y z."""
    half = 0.5 * np.asarray(angle, float)
    q = np.zeros((len(half), 4))
    q[:, 0], q[:, " xyz".index(axis)] = np.cos(half), np.sin(half)
    return q


def _qmul(p: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Hamilton products of quaternion stacks (N, 4), w x y z: the turn p, then q in p's frame."""
    pw, pv, qw, qv = p[:, :1], p[:, 1:], q[:, :1], q[:, 1:]
    out = np.empty(np.broadcast_shapes(p.shape, q.shape))
    out[:, :1] = pw * qw - np.sum(pv * qv, axis=1, keepdims=True)
    out[:, 1:] = pw * qv + qw * pv
    # pv x qv written out (np.cross's axis handling costs more than its arithmetic here)
    out[:, 1] += pv[:, 1] * qv[:, 2] - pv[:, 2] * qv[:, 1]
    out[:, 2] += pv[:, 2] * qv[:, 0] - pv[:, 0] * qv[:, 2]
    out[:, 3] += pv[:, 0] * qv[:, 1] - pv[:, 1] * qv[:, 0]
    return out


def joint_frames(
    convention: str, a, d, alpha, theta, beta
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Each joint's two rigid pieces around its hinge, for (N,) values (metres as given):
    (pre_R (N, 3, 3), pre_t (N, 3)) the hinge frame in the previous link frame, (post_R, post_t)
    the link frame in the hinge frame."""
    a, d, alpha, theta, beta = (
        np.atleast_1d(np.asarray(v, float)) for v in (a, d, alpha, theta, beta)
    )
    zero, eye = np.zeros(len(a)), np.broadcast_to(np.eye(3), (len(a), 3, 3))
    M = _rot("x", alpha) @ _rot("y", beta)
    if convention == "dh":  # RotZ(theta + q) | TransZ(d) TransX(a) RotX(alpha) RotY(beta)
        return _rot("z", theta), np.zeros((len(a), 3)), M, np.stack([a, zero, d], axis=1)
    # mdh: RotX(alpha) RotY(beta) TransX(a) RotZ(theta + q) | TransZ(d)
    return M @ _rot("z", theta), a[:, None] * M[:, :, 0], eye, np.stack([zero, zero, d], axis=1)


def joint_quats(convention: str, alpha, theta, beta) -> tuple[np.ndarray, np.ndarray]:
    """:func:`joint_frames`' pre_R and post_R as unit quaternions (N, 4), w x y z, made from the
    half angles (a quaternion read back from a matrix would cost ten times as much)."""
    alpha, theta, beta = (np.atleast_1d(np.asarray(v, float)) for v in (alpha, theta, beta))
    M = _qmul(_quat("x", alpha), _quat("y", beta))
    if convention == "dh":
        return _quat("z", theta), M
    return _qmul(M, _quat("z", theta)), _quat("x", np.zeros(len(alpha)))


@dataclasses.dataclass(frozen=True)
class _Links:
    """The as-built numbers of the MJCF's bodies, per joint i (metres, unit quaternions w x y z):
    hinge body ``joint{i}`` at pre_t (N, 3) turned by pre_quat (N, 4); link body ``link{i}`` at
    post_t, post_quat in it; the link's mass (N,), centre com (N, 3) and rod inertia (N,) in the
    hinge body; its capsule from the hinge to post_t (a sphere where that is shorter than 1 um);
    the tool points tools (T, 3), each in its joint's link frame."""

    pre_t: np.ndarray
    pre_quat: np.ndarray
    post_t: np.ndarray
    post_quat: np.ndarray
    mass: np.ndarray
    com: np.ndarray
    inertia: np.ndarray
    capsule: tuple
    tools: np.ndarray


def _links(arm: ArmDescription, values: np.ndarray | None, tool_mm) -> _Links:
    """:class:`_Links` of ``arm`` with as-built ``values`` (N, 5) and ``tool_mm`` (3,), or (T, 3)
    for an arm with several tools (nominal when None)."""
    N = arm.n_joints
    values = np.asarray(arm.nominal() if values is None else values, float)
    a, d, al, th, be = values.T
    _, pre_t, post_R, post_t = joint_frames(arm.convention, a / 1000, d / 1000, al, th, be)
    pre_quat, post_quat = joint_quats(arm.convention, al, th, be)
    if arm.has_masses:
        mass = np.maximum(np.asarray(arm.mass_kg, float), 1e-6)
        com = np.einsum("nij,nj->ni", post_R, np.asarray(arm.com_mm, float) / 1000) + post_t
        # statics need only mass and centre; the inertia is a rod's, for stepping
        inertia = mass * (0.05**2 + np.sum(post_t * post_t, axis=1) / 12)
    else:
        mass, com, inertia = np.full(N, 0.1), post_t / 2, np.full(N, 1e-3)
    tool = np.asarray(arm.tool_offsets() if tool_mm is None else tool_mm, float).reshape(-1, 3)
    tool = tool / 1000
    return _Links(
        pre_t,
        pre_quat,
        post_t,
        post_quat,
        mass,
        com,
        inertia,
        tuple(bool(x) for x in np.linalg.norm(post_t, axis=1) > 1e-6),
        tool,
    )


def _across(link: np.ndarray) -> np.ndarray:
    """Two unit axes (2, 3) across a link running along ``link`` (3,) and across each other."""
    u = link / np.linalg.norm(link)
    other = np.eye(3)[int(np.argmin(np.abs(u)))]
    a = np.cross(u, other)
    a /= np.linalg.norm(a)
    return np.stack([a, np.cross(u, a)])


def _g(v) -> str:
    """Floats as MJCF text that parses back to the same doubles."""
    return " ".join(f"{x:.17g}" for x in np.atleast_1d(v))


def _flexing(arm: ArmDescription, bend, flex) -> dict[int, float]:
    """{link j (1-based): its flex springs' stiffness}: ``bend``'s one and ``flex``'s."""
    out = dict(flex or {})
    if bend is not None:
        out[int(bend[0])] = float(bend[1])
    for j in out:
        if not 1 <= j <= arm.n_joints:
            raise ValueError(f"link {j} to flex: the arm has links 1..{arm.n_joints}")
    return out


def _body(arm: ArmDescription, L: _Links, k: np.ndarray, flex: dict, i: int) -> str:
    """Joint i's (0-based) body, its link's and, nested in the link, its children's and its
    tools': a serial arm's chain of bodies is each joint's one child. On a link that flexes
    (``flex``), the outer segment sits on two springs across it halfway."""
    spring = f' stiffness="{k[i]:.17g}"' if np.isfinite(k[i]) else ""
    geom = (
        f'<geom type="capsule" fromto="0 0 0 {_g(L.post_t[i])}" size="0.03" rgba="0.75 0.75 '
        '0.78 1"/>'
        if L.capsule[i]
        else '<geom type="sphere" size="0.035" rgba="0.75 0.75 0.78 1"/>'
    )
    # armature 0.1 kg m^2: a geared motor's rotor seen through its reduction; with the 0.5 ms
    # step it keeps a stiff joint's spring stable when the model is stepped
    text = f"""
      <body name="joint{i + 1}" pos="{_g(L.pre_t[i])}" quat="{_g(L.pre_quat[i])}">
        <joint name="q{i + 1}" type="hinge" axis="0 0 1" damping="2" armature="0.1"{spring}/>
        <inertial pos="{_g(L.com[i])}" mass="{L.mass[i]:.17g}"
            diaginertia="{_g([L.inertia[i]] * 3)}"/>
        {geom}"""
    link_at, close = _g(L.post_t[i]), "\n        </body>\n      </body>"
    if i + 1 in flex:  # the outer segment, on a spring halfway
        across, kf = _across(L.post_t[i]), flex[i + 1]
        text += f"""
        <body name="bend{i + 1}" pos="{_g(L.post_t[i] / 2)}">
        <joint name="bend{i + 1}a" type="hinge" axis="{_g(across[0])}" stiffness="{kf:.17g}"/>
        <joint name="bend{i + 1}b" type="hinge" axis="{_g(across[1])}" stiffness="{kf:.17g}"/>
        <inertial pos="0 0 0" mass="1e-6" diaginertia="1e-9 1e-9 1e-9"/>"""
        link_at, close = _g(L.post_t[i] / 2), close + "\n        </body>"
    text += f"""
        <body name="link{i + 1}" pos="{link_at}" quat="{_g(L.post_quat[i])}">"""
    parents = arm.parents()
    text += "".join(
        _body(arm, L, k, flex, c) for c in range(i + 1, arm.n_joints) if parents[c] == i + 1
    )
    masses = arm.tool_masses()
    for t, at in enumerate(arm.tool_joints()):
        if at != i + 1:
            continue
        name = "" if t == 0 else str(t + 1)
        flange = '\n          <site name="flange" pos="0 0 0" size="0.005" rgba="0.3 0.3 0.9 1"/>'
        text += f"""{flange if t == 0 else ""}
          <site name="probe{name}" pos="{_g(L.tools[t])}" size="0.006" rgba="0.9 0.2 0.2 1"/>
          <body name="tool{name}" pos="{_g(L.tools[t])}">
            <inertial pos="0 0 0" mass="{max(masses[t], 1e-6):.17g}" diaginertia="1e-5 1e-5 1e-5"/>
          </body>"""
    return text + close


def build_mjcf(
    arm: ArmDescription,
    values: np.ndarray | None = None,
    tool_mm=None,
    stiffness_nm_per_rad=None,
    tracker_pos_m=None,
    tracker_quat=None,
    cones_m=None,
    bend: tuple[int, float] | None = None,
    flex: dict[int, float] | None = None,
) -> str:
    """MJCF of ``arm`` built with as-built ``values`` (N, 5): a, d (mm), alpha, theta, beta (rad)
    per joint (nominal when None), the tool point ``tool_mm`` (3,), each hinge's spring
    ``stiffness_nm_per_rad`` (N,) (none when None or inf), the tracker's pose and the cones.
    ``bend``: (link j, stiffness N m / rad): link j made of two segments joined halfway by two
    hinges ``bend{j}a``, ``bend{j}b`` across it, each with that spring (a link that bends under
    the load it carries, either way; the second suite's), the rest of the chain on the outer
    segment. ``flex``: {link j: stiffness N m / rad}, as many such links as given (a branched
    arm's lateral compliance). A branched arm's joints nest in their parents' links, each tool
    on its joint's link (site ``probe``, body ``tool``; ``probe2``, ``tool2``, ... for the
    others), a follower held to the joints it follows by an equality on a fixed tendon."""
    N = arm.n_joints
    k = (
        np.full(N, np.inf)
        if stiffness_nm_per_rad is None
        else np.asarray(stiffness_nm_per_rad, float)
    )
    g = arm.gravity_m_s2
    L = _links(arm, values, tool_mm)
    flex = _flexing(arm, bend, flex)
    roots = [i for i in range(N) if arm.parents()[i] == 0]
    body = "".join(_body(arm, L, k, flex, i) for i in roots)
    world = ""
    if tracker_pos_m is not None:
        tp = np.asarray(tracker_pos_m, float)
        world += (
            f'\n    <body name="tracker" pos="{tp[0]:.17g} {tp[1]:.17g} {tp[2]:.17g}" '
            f'quat="{" ".join(f"{v:.17g}" for v in tracker_quat)}">'
            '<geom name="tracker_head" type="box" size="0.08 0.06 0.1" rgba="0.85 0.85 0.8 '
            '1"/></body>'
        )
    if cones_m is not None:
        ca, cb = (np.asarray(c, float) for c in cones_m)
        world += f"""
    <geom name="cone_a" type="cylinder" size="0.01 0.01" pos="{ca[0]} {ca[1]} {ca[2] - 0.01}"
        rgba="0.2 0.6 0.9 1"/>
    <geom name="cone_b" type="cylinder" size="0.01 0.01" pos="{cb[0]} {cb[1]} {cb[2] - 0.01}"
        rgba="0.2 0.6 0.9 1"/>
    <geom name="length_bar" type="capsule"
        fromto="{ca[0]} {ca[1]} {ca[2] - 0.02} {cb[0]} {cb[1]} {cb[2] - 0.02}" size="0.008"
        rgba="0.3 0.3 0.35 1"/>"""
    reach = max(arm.reach_mm / 1000, 0.5)
    xml = _with_cables(
        arm,
        f"""
<mujoco model={quoteattr(arm.name)}>
  <compiler angle="radian" autolimits="true"/>
  <option gravity="{g[0]:.17g} {g[1]:.17g} {g[2]:.17g}" timestep="0.0005">
    <flag contact="disable"/>
  </option>
  <visual><global offwidth="640" offheight="480"/></visual>
  <worldbody>
    <light name="top" pos="0 0 {2 * reach:.3f}" dir="0 0 -1" directional="true" castshadow="false"/>
    <geom name="floor" type="plane" size="{2 * reach:.3f} {2 * reach:.3f} 0.01"
        pos="0 0 {-0.35 * reach:.3f}" rgba="0.2 0.22 0.25 1"/>
    <geom name="pedestal" type="cylinder" size="0.06 {0.17 * reach:.3f}"
        pos="0 0 {-0.18 * reach:.3f}" rgba="0.3 0.3 0.32 1"/>{world}
    <body name="base" pos="0 0 0">{body}
    </body>
  </worldbody>
</mujoco>
""",
    )
    return _with_followers(arm, xml)


def _with_cables(arm: ArmDescription, xml: str) -> str:
    """``xml`` with one fixed tendon per motor of an arm with a transmission: its length is the
    motor's angle seen from the joints (the inverse coupling's row), its spring the cable's
    (stiffness 0 for a rigid one; the simulation sets it and the rest lengths)."""
    if arm.coupling is None and arm.cable_stiffness_nm_per_rad is None:
        return xml
    inv = np.linalg.inv(arm.motor_to_joint())
    c = arm.cable_compliance()
    k = np.where(c > 0, 1.0 / np.where(c > 0, c, 1.0), 0.0)
    cables = ""
    for m in range(arm.n_joints):
        joints = "".join(
            f'<joint joint="q{j + 1}" coef="{inv[m, j]:.17g}"/>'
            for j in range(arm.n_joints)
            if inv[m, j] != 0
        )
        cables += f'\n    <fixed name="cable{m + 1}" stiffness="{k[m]:.17g}">{joints}</fixed>'
    return xml.replace("</worldbody>", f"</worldbody>\n  <tendon>{cables}\n  </tendon>", 1)


# a follower's coupling, as stiff as the 0.5 ms step allows: the statics set its angle from the
# joints it follows exactly (sim.arm_cmm); the constraint is what stepping the model holds
FOLLOW_SOLREF, FOLLOW_SOLIMP = "0.001 1", "0.9999 0.9999 0.001"


def _with_followers(arm: ArmDescription, xml: str) -> str:
    """``xml`` with each follower held to the joints it follows: a fixed tendon q_f - a q_i -
    b q_j (its length zero at the arm's zero posture) and an equality keeping it there."""
    if not arm.followers():
        return xml
    tendons, equalities = "", ""
    for f in arm.followers():
        row = arm.follows[f - 1]  # type: ignore[index]
        joints = f'<joint joint="q{f}" coef="1"/>' + "".join(
            f'<joint joint="q{k + 1}" coef="{-a:.17g}"/>' for k, a in enumerate(row) if a != 0.0
        )
        tendons += f'\n    <fixed name="follow{f}">{joints}</fixed>'
        equalities += (
            f'\n    <tendon name="follows{f}" tendon1="follow{f}" solref="{FOLLOW_SOLREF}" '
            f'solimp="{FOLLOW_SOLIMP}"/>'
        )
    return xml.replace(
        "</worldbody>",
        f"</worldbody>\n  <tendon>{tendons}\n  </tendon>\n  <equality>{equalities}\n  </equality>",
        1,
    )


def _key(v) -> tuple | None:
    return None if v is None else tuple(np.ravel(np.asarray(v, float)).tolist())


_SPEC_LOCK = (
    threading.Lock()
)  # a Dask worker may run trials in threads: one edits the spec at a time


@functools.lru_cache(maxsize=8)
def _spec(arm: ArmDescription, stiffness, tracker_pos, tracker_quat, cones):
    """The nominal arm's parsed MJCF (an MjSpec) for one setup, and its links' capsule pattern."""
    import mujoco

    c = None if cones is None else (cones[:3], cones[3:])
    xml = build_mjcf(arm, None, None, stiffness, tracker_pos, tracker_quat, c)
    return mujoco.MjSpec.from_string(xml), _links(arm, None, None).capsule


def as_built_model(
    arm: ArmDescription,
    values: np.ndarray,
    tool_mm,
    stiffness_nm_per_rad=None,
    tracker_pos_m=None,
    tracker_quat=None,
    cones_m=None,
    flex: dict[int, float] | None = None,
):
    """The MjModel of :func:`build_mjcf` with the same arguments, without writing and parsing the
    MJCF each time: the nominal arm's MJCF is parsed once per arm and setup, and each as-built
    arm writes its frames, centres of mass and tools into that spec before compiling (a
    Monte-Carlo trial makes one per trial). A test checks every array of the model against the
    MJCF's. An arm whose links flex (``flex``) is compiled from its MJCF (its flex hinges' axes
    follow each as-built link)."""
    import mujoco

    L = _links(arm, values, tool_mm)
    spec, capsule = _spec(
        arm, _key(stiffness_nm_per_rad), _key(tracker_pos_m), _key(tracker_quat), _key(cones_m)
    )
    if L.capsule != capsule or flex:  # a link's capsule became a sphere or back: another MJCF
        return mujoco.MjModel.from_xml_string(
            build_mjcf(
                arm,
                values,
                tool_mm,
                stiffness_nm_per_rad,
                tracker_pos_m,
                tracker_quat,
                cones_m,
                flex=flex,
            )
        )
    with _SPEC_LOCK:
        for i in range(arm.n_joints):
            hinge, link = spec.body(f"joint{i + 1}"), spec.body(f"link{i + 1}")
            hinge.pos, hinge.quat, hinge.ipos = L.pre_t[i], L.pre_quat[i], L.com[i]
            hinge.inertia = [L.inertia[i]] * 3
            link.pos, link.quat = L.post_t[i], L.post_quat[i]
            if L.capsule[i]:
                hinge.geoms[0].fromto = np.r_[0.0, 0.0, 0.0, L.post_t[i]]
        for t, name in enumerate(_tool_names(L)):
            spec.site(f"probe{name}").pos = L.tools[t]
            spec.body(f"tool{name}").pos = L.tools[t]
        return spec.compile()


def _tool_names(L: _Links) -> list[str]:
    """The tools' suffixes in the MJCF: ``probe``, ``tool`` for the first, ``probe2`` ... after."""
    return ["" if t == 0 else str(t + 1) for t in range(len(L.tools))]


def write_as_built(model, arm: ArmDescription, values: np.ndarray, tool_mm) -> bool:
    """Write an as-built arm into ``model`` in place, without compiling: an MjModel of
    :func:`as_built_model` for the same arm and setup, reused from trial to trial (a Monte-Carlo
    trial's twin). Written: each hinge body's frame, centre of mass and inertia, each link
    frame, each capsule's pose and length (MuJoCo's own z-to-vector turn, as its compiler
    turns a ``fromto``), the tool: what kinematics, inverse dynamics and rendering read (a test
    checks them against the compiled model's, and the points and gravity torques). Not written:
    the inertial frames of the massless link bodies, which nothing reads, and the collision
    bounding volumes (contacts are off); ``mj_setConst`` redoes what the compiler derives at
    qpos0 (the caller's, with its data). False, nothing written, when a link's capsule
    became a sphere or back (another MJCF)."""
    import mujoco

    L = _links(arm, values, tool_mm)
    N = arm.n_joints
    hinge = [model.body(f"joint{i + 1}").id for i in range(N)]
    geom = model.body_geomadr[hinge]
    if tuple(bool(t) for t in model.geom_type[geom] == mujoco.mjtGeom.mjGEOM_CAPSULE) != L.capsule:
        return False
    link = [model.body(f"link{i + 1}").id for i in range(N)]
    model.body_pos[hinge], model.body_quat[hinge], model.body_ipos[hinge] = (
        L.pre_t,
        L.pre_quat,
        L.com,
    )
    model.body_inertia[hinge] = L.inertia[:, None]
    model.body_pos[link], model.body_quat[link] = L.post_t, L.post_quat
    caps = np.flatnonzero(L.capsule)
    g = geom[caps]
    half = 0.5 * np.sqrt(np.sum(L.post_t[caps] ** 2, axis=1))
    model.geom_pos[g] = 0.5 * L.post_t[caps]
    quat = model.geom_quat
    for i, gi in zip(caps, g):
        mujoco.mju_quatZ2Vec(quat[gi], -L.post_t[i])  # the compiler's fromto: z from "to" to "from"
    model.geom_size[g, 1] = half
    model.geom_rbound[g] = model.geom_size[g, 0] + half
    model.geom_aabb[g, 5] = model.geom_size[g, 0] + half
    for t, name in enumerate(_tool_names(L)):
        model.site_pos[model.site(f"probe{name}").id] = L.tools[t]
        model.body_pos[model.body(f"tool{name}").id] = L.tools[t]
    return True


def default_scenes() -> dict:
    """The built-in arms with their tracker, cones and a spring on every joint (its sag under
    gravity is what the steps settle), for the scene tests: {arm's name: () -> (MJCF, assets)}."""
    from calibench.scenes.arm_cmm import BUILTIN, load_arm

    def scene(name: str, stiffness_nm_per_rad: float):
        arm = load_arm(name)
        k = [stiffness_nm_per_rad] * arm.n_joints
        cones = ((0.45, 0.25, -0.15), (0.45, -0.35, -0.15))
        return build_mjcf(arm, None, None, k, (2.2, -0.9, 0.35), (1, 0, 0, 0), cones), {}

    # the UR10 is ten times heavier: a ten times stiffer spring keeps its sag alike
    stiffness = {name: 2e5 if name == "ur10" else 2e4 for name in BUILTIN}
    return {name: functools.partial(scene, name, k) for name, k in stiffness.items()}
