"""Concealed effects that no candidate writes down: the second suite's.

The first suite's effects are, for the most part, the very formulas of the candidates that find
them (a reversal of +-B/2, k dT u, A sin(h q + phi)). These are made by mechanisms the candidate
library does not contain, so discovery can only name the nearest effect it knows, or say where
the residual lives; each truth carries that ``nearest`` name for the suite to score.

Stages:

- ``presliding``: the drive's friction builds up over a presliding distance after each reversal
  (Dahl's model), so the lost motion is reached gradually, not at once: e = dir B/2 (1 - 2
  exp(-s / lambda)), s the travel since the last reversal. Nearest: ``backlash`` (its
  ``reversal_transient``, of -B over lambda, is alike: the rest of the same mechanism).
- ``lagged_thermal``: the scale's own temperature follows the logged air through a first-order
  lag of 15-40 min, so its expansion is not proportional to the logged temperature. Nearest:
  ``thermal_expansion`` on each axis.
- ``rail_step``: the X rail is two segments joined with a step in straightness (smoothed over a
  few mm), not a bump. Nearest: ``nonsmooth`` on y, located at the joint (its smooth part may
  be named ``straightness`` beside it).

Stewart platform:

- ``stick_slip``: one leg's hinges stick and slip: the leg comes to rest anywhere within its
  friction band, so what it loses on a reversal differs from one visit to the next (30-100 % of
  a 10-20 um band). Nearest: ``backlash`` on that leg.
- ``sensor_warmup``: one leg's length sensor settling from power-on (:func:`stewart_effect`).
  Nearest: ``thermal_drift`` on that leg.
- ``tracker_air``: the laser tracker reads every distance long by the air's index change as
  the room warms, its compensation left at the start (:func:`tracker_air`). Nearest: the
  tracker's ``thermal_drift`` (any ``thermal_drift`` on the legs; a leg's ``thermal_expansion``
  is alike).

Arms:

- ``harmonic_drive``: the most loaded joint's strain-wave gear winds up under gravity's torque
  (MuJoCo's inverse dynamics at the settled posture) with the catalogue's three stiffness
  segments (K1 to T1, K2 to T2, K3 beyond), not one linear spring, and its kinematic error's
  harmonic grows and shifts with the torque. Nearest: ``joint_compliance`` on that joint (a
  ``transmission`` there is alike).
- ``link_bending``: the longest loaded link is two segments joined halfway by springs across
  it (a segmented body in MuJoCo, not a joint spring): it bends under the gravity load of all
  it carries, where MuJoCo's statics put it, by 100-300 urad at most. Nearest:
  ``joint_compliance`` on the nearest joint on either side whose axis lies across the link (a
  compliance on any other joint is alike).

Probe scanner:

- ``thin_wall``: the plate's wall is ground thin over an arc; the stylus's spring pushes it out
  by the force over the wall's bending stiffness, which falls as the thickness cubed. Nearest:
  ``nonsmooth``, located on the arc.
"""

from __future__ import annotations

import numpy as np

UNWRITTEN_STAGE_KINDS = ("presliding", "lagged_thermal", "rail_step")
UNWRITTEN_SCANNER_KINDS = ("thin_wall",)
UNWRITTEN_STEWART_KINDS = ("stick_slip", "sensor_warmup", "tracker_air")
AIR_INDEX_PER_K = 0.93e-6  # air's refractive index falls this much per K near 20 C, 1 atm
UNWRITTEN_ARM_KINDS = ("harmonic_drive", "link_bending", "pedestal_warmup")
BEND_MIN_LINK_MM = 100.0  # a link this long at least, to bend
# a strain-wave gear's catalogue stiffness: K2 and K3 over K1, above T1 and T2 (shares of the
# largest torque); Harmonic Drive's CSF series run about 1 : 1.6 : 1.8
GEAR_STIFFENING = (1.0, 1.6, 2.0)
GEAR_KNEES = (0.2, 0.6)


def first_order_lag(t: np.ndarray, u: np.ndarray, tau: float) -> np.ndarray:
    """``u`` (n,) seen through a first-order lag of time constant ``tau`` (the step exact for
    each sample interval of ``t`` (n,)); starts settled at ``u[0]``."""
    a = np.exp(-np.diff(t, prepend=t[0]) / tau)
    out = np.empty_like(u)
    out[0] = u[0]
    for i in range(1, len(u)):  # a recursion: each sample needs the last
        out[i] = a[i] * out[i - 1] + (1 - a[i]) * u[i]
    return out


def travel_since_reversal(u: np.ndarray, direction: np.ndarray) -> np.ndarray:
    """Distance (n,) each axis has travelled since its last reversal: ``u`` (n,) its commanded
    position, ``direction`` (n,) +-1 the way it last moved."""
    n = len(u)
    change = np.r_[True, direction[1:] != direction[:-1]]
    start = np.maximum.accumulate(np.where(change, np.arange(n), 0))
    turned_at = u[np.maximum(start - 1, 0)]  # the reversal: the station before the new direction
    return np.abs(u - turned_at)


def stage_effect(
    kind: str,
    rng: np.random.Generator,
    c: dict,
    travel_mm: tuple[float, float],
    temp_c: np.ndarray,
) -> tuple[np.ndarray, list[dict], np.ndarray]:
    """The error (n, 2) mm of an unwritten stage effect, its truth and the logged temperature.

    Parameters
    ----------
    kind : str
        One of :data:`UNWRITTEN_STAGE_KINDS`.
    rng : numpy.random.Generator
        The recording's generator.
    c : dict
        The plan's commands (``stage_commands``): ``x``, ``y``, ``dir_x``, ``dir_y``, ``t_s``.
    travel_mm : tuple of float
        (X, Y) travel.
    temp_c : (n,) the logged air temperature before the effect.

    Returns
    -------
    err : (n, 2) ndarray
    effects : list of dict
        The truth, each with ``nearest`` (the named effect discovery should report).
    temp_c : (n,) ndarray
        The logged temperature (a warming room for ``lagged_thermal``).
    """
    x, y, t = c["x"], c["y"], c["t_s"]
    err = np.zeros((len(x), 2))
    if kind == "presliding":
        a = str(rng.choice(["x", "y"]))
        B, lam = rng.uniform(8, 15) / 1000, rng.uniform(3, 10)
        u, d = c[a], c[f"dir_{a}"]
        s = travel_since_reversal(u, d)
        err[:, "xy".index(a)] = d * B / 2 * (1 - 2 * np.exp(-s / lam))
        said = {
            "name": "presliding_friction",
            "axis": a,
            "nearest": "backlash",
            # e = backlash + a transient of -B decaying over lambda: the transient is its part
            "alike": ["reversal_transient"],
        }
        return err, [{**said, "params": {"reversal_mm": B, "presliding_mm": lam}}], temp_c
    if kind == "lagged_thermal":
        rise, tau_air = rng.uniform(2, 5), t[-1] / rng.uniform(1.5, 3)
        temp_c = temp_c + rise * (1 - np.exp(-t / tau_air))
        tau_scale, k = rng.uniform(15, 40) * 60, rng.uniform(10, 25)
        scale_c = first_order_lag(t, temp_c, tau_scale)
        effects = []
        for i, (a, u) in enumerate((("x", x), ("y", y))):
            err[:, i] = k * 1e-6 * (scale_c - scale_c[0]) * u
            effects.append(
                {
                    "name": "lagged_thermal_expansion",
                    "axis": a,
                    "nearest": "thermal_expansion",
                    "params": {"ppm_per_k": k, "lag_s": tau_scale},
                }
            )
        return err, effects, temp_c
    if kind == "rail_step":
        x0, h, w = rng.uniform(0.25, 0.75) * travel_mm[0], rng.uniform(6, 12) / 1000, 2.0
        err[:, 1] = h / 2 * (1 + np.tanh((x - x0) / w))
        # a step is also a straightness error: its smooth part may be named so beside it
        step = {"x_mm": x0, "step_mm": h, "width_mm": w}
        return (
            err,
            [
                {
                    "name": "rail_step",
                    "axis": "y",
                    "nearest": "nonsmooth",
                    "alike": ["straightness"],
                    "params": step,
                }
            ],
            temp_c,
        )
    raise ValueError(f"unknown kind {kind!r}")


def thin_wall_deflection(
    rng: np.random.Generator, theta_rad: np.ndarray
) -> tuple[np.ndarray, dict]:
    """How far (n,) mm the stylus pushes the plate's wall out at ``theta_rad`` (n,), where an
    arc of 15-40 deg is ground down to 55-70 % of the wall's thickness (a raised-cosine
    profile), and the truth. The push is the stylus force over the wall's bending stiffness,
    which goes as the thickness cubed; 4-10 um at the thinnest, nothing at full thickness."""
    th0, width = rng.uniform(0, 360), rng.uniform(15, 40)
    thinnest, push_um = rng.uniform(0.55, 0.70), rng.uniform(4, 10)
    off = (np.degrees(theta_rad) - th0 + 180) % 360 - 180
    window = np.where(np.abs(off) < width / 2, 0.5 * (1 + np.cos(2 * np.pi * off / width)), 0.0)
    thickness = 1 - (1 - thinnest) * window  # relative to the rest of the wall
    # compliance ~ thickness^-3, scaled so the thinnest point gives push_um beyond the rest
    dz = (thickness**-3 - 1) / (thinnest**-3 - 1) * push_um / 1000
    truth = {
        "name": "thin_wall",
        "axis": "rho",
        "nearest": "nonsmooth",
        "params": {"theta_deg": th0, "width_deg": width, "push_mm": push_um / 1000},
    }
    return dz, truth


def stewart_effect(
    kind: str, rng: np.random.Generator, direction: np.ndarray, leg: int, t_s: np.ndarray
) -> tuple[np.ndarray, dict]:
    """The error (n, 6) mm of an unwritten Stewart effect on ``leg`` (1-6), and its truth.
    ``direction`` (n, 6): the way each leg last moved (+-1); ``t_s`` (n,) when each pose was
    read.

    - ``stick_slip``: the leg stops anywhere in a friction band, on the side it came from;
    - ``sensor_warmup``: the leg's length sensor warms up from power-on through the session, its
      zero settling as a first-order lag (time constant a third of the recording to all of it)
      by 10-25 um: no candidate writes an exponential in time (nearest: ``thermal_drift``, a
      slope and a bend in it). A warm-up over within the first fifth is not in the suite: the
      contiguous folds hold that fifth out whole, and nothing fitted on the rest predicts it.
    """
    if kind == "sensor_warmup":
        shift, tau = rng.uniform(10, 25) / 1000, rng.uniform(1 / 3, 1) * float(np.ptp(t_s))
        err = np.zeros(direction.shape)
        err[:, leg - 1] = shift * (1 - np.exp(-(t_s - t_s[0]) / tau))
        truth = {"name": "sensor_warmup", "axis": "legs", "nearest": "thermal_drift"}
        return err, {**truth, "params": {"leg": leg, "shift_mm": shift, "tau_s": tau}}
    if kind != "stick_slip":
        raise ValueError(f"unknown kind {kind!r}")
    band = rng.uniform(10, 20) / 1000
    rest = rng.uniform(0.3, 1.0, len(direction))  # where in the band each visit stopped
    err = np.zeros(direction.shape)
    err[:, leg - 1] = direction[:, leg - 1] * band / 2 * rest
    truth = {"name": "stick_slip", "axis": "legs", "nearest": "backlash"}
    return err, {**truth, "params": {"leg": leg, "band_mm": band}}


def tracker_air(
    rng: np.random.Generator, temp_c: np.ndarray, t_s: np.ndarray
) -> tuple[np.ndarray, np.ndarray, float, dict]:
    """A tracker set back 5-10 m in the hall whose air compensation stays at the session's start
    (its weather station unplugged): the room warms by 3-6 K
    (a first-order rise, time constant half the recording), the air's refractive index falls
    :data:`AIR_INDEX_PER_K` per K and every distance the tracker measures reads long by as much
    (a scale about the tracker's own origin, metres away). The logged temperature rises with the
    room. Nearest: ``thermal_drift`` on the legs (every leg: each sees the platform's apparent
    shift along the tracker's line of sight as its own direction takes it).

    Returns
    -------
    temp_c : (n,) ndarray
        The logged temperature, risen.
    range_scale : (n,) ndarray
        The share by which each pose's distances read long.
    range_mm : float
        How far from the platform the tracker stands.
    truth : dict
    """
    rise, distance = rng.uniform(3, 6), rng.uniform(5000, 10000)
    warm = rise * (1 - np.exp(-(t_s - t_s[0]) / (np.ptp(t_s) / 2)))
    truth = {
        "name": "tracker_air",
        "axis": "legs",
        "nearest": "thermal_drift",
        "alike": ("thermal_expansion",),
        "params": {"ppm_per_k": AIR_INDEX_PER_K * 1e6, "rise_k": rise, "range_mm": distance},
    }
    return temp_c + warm, AIR_INDEX_PER_K * warm, distance, truth


def _windup(torque: np.ndarray, knees: tuple, k1: float) -> np.ndarray:
    """A strain-wave gear's wind-up (rad) under ``torque`` (n,) N m: K1 up to the first knee, K2
    to the second, K3 beyond (:data:`GEAR_STIFFENING` times K1)."""
    t = np.abs(torque)
    k = [k1 * s for s in GEAR_STIFFENING]
    lo, hi = knees
    angle = np.minimum(t, lo) / k[0]
    angle += np.clip(t - lo, 0.0, hi - lo) / k[1] + np.maximum(t - hi, 0.0) / k[2]
    return np.sign(torque) * angle


def harmonic_drive_angles(sim, q_motor: np.ndarray, rng: np.random.Generator):
    """The links' true angles (n, N) of a rigid twin ``sim`` (an ``ArmSim``) whose most loaded
    joint turns through a strain-wave gear: wound up by gravity's torque where the links settle
    (fixed point on MuJoCo's inverse dynamics), plus a kinematic error at 8-40 cycles per turn
    whose amplitude grows by up to 80 % and whose phase shifts by up to 0.5 rad with the torque.
    Returns the angles and the truth."""
    tau = sim.gravity_torques(q_motor)
    j = int(np.argmax(np.abs(tau).max(axis=0)))
    t_max = float(np.abs(tau[:, j]).max())
    windup = rng.uniform(100, 300) * 1e-6  # at the largest torque
    knees = (GEAR_KNEES[0] * t_max, GEAR_KNEES[1] * t_max)
    k1 = float(_windup(np.array([t_max]), knees, 1.0)[0]) / windup
    h, a0, ph = rng.uniform(8, 40), rng.uniform(60, 120) * 1e-6, rng.uniform(0, 2 * np.pi)
    q = q_motor.copy()
    for _ in range(20):
        t = sim.gravity_torques(q)[:, j]
        load = t / t_max
        new = q_motor.copy()
        new[:, j] += _windup(t, knees, k1) + a0 * (1 + 0.8 * np.abs(load)) * np.sin(
            h * q_motor[:, j] + ph + 0.5 * load
        )
        done = np.abs(new - q).max() < 1e-12
        q = new
        if done:
            break
    truth = {
        "name": "harmonic_drive",
        "axis": "xyz",
        "nearest": "joint_compliance",
        "alike": ["transmission"],
        "params": {
            "joint": j + 1,
            "windup_urad": windup * 1e6,
            "k1_nm_per_rad": k1,
            "harmonic": h,
            "amplitude_urad": a0 * 1e6,
            "phase_rad": ph,
        },
    }
    return q, truth


def bent_link_points(sim, q_motor: np.ndarray, rng: np.random.Generator):
    """The tool points (n, 3) mm, base frame, of the twin ``sim`` (an ``ArmSim``, rigid) with
    its most loaded long link bent halfway under gravity: a MuJoCo model of the same as-built
    arm whose link j is two segments on springs across it (``build_mjcf(..., bend=)``), the
    springs' angles solved at each posture where they hold MuJoCo's gravity torque on them
    (fixed point on inverse dynamics), the motors at ``q_motor`` (n, N). Returns the points and
    the truth."""
    import mujoco

    from calibench.errors import BadInput
    from calibench.scenes.arm_mjcf import build_mjcf
    from calibench.sim.arm_cmm import gravity_at_rest

    arm, N = sim.arm, sim.n_joints
    values = arm.nominal() + sim.delta[: 5 * N].reshape(N, 5)
    tool = np.asarray(arm.tool_mm) + sim.delta[5 * N :]
    length = np.hypot(values[:, 0], values[:, 1])
    tau = np.abs(sim.gravity_torques(q_motor)).max(axis=0)
    long = np.flatnonzero(length >= BEND_MIN_LINK_MM)
    if not len(long):
        raise BadInput(f"the arm {arm.name} has no link {BEND_MIN_LINK_MM:g} mm long to bend")
    # the longest link under load: a beam's bend grows with the square of its length
    loaded = long[tau[long] >= 0.1 * tau.max()]
    j = int(loaded[np.argmax(length[loaded])]) if len(loaded) else int(long[np.argmax(tau[long])])

    def settle(k: float) -> tuple[np.ndarray, np.ndarray]:
        model = mujoco.MjModel.from_xml_string(build_mjcf(arm, values, tool, bend=(j + 1, k)))
        data = mujoco.MjData(model)
        hinge = [model.joint(f"q{i + 1}").qposadr[0] for i in range(N)]
        springs = [model.joint(f"bend{j + 1}{s}") for s in "ab"]
        at, dof = [b.qposadr[0] for b in springs], [b.dofadr[0] for b in springs]
        probe, rne = model.site("probe").id, np.zeros(model.nv)
        points, angles = np.empty((len(q_motor), 3)), np.empty((len(q_motor), 2))
        for i, q in enumerate(q_motor):
            data.qpos[:] = 0.0
            data.qpos[hinge] = q
            for _ in range(50):
                new = gravity_at_rest(model, data, rne)[dof] / k  # the springs hold it
                done = np.abs(new - data.qpos[at]).max() < 1e-13
                data.qpos[at] = new
                if done:
                    break
            mujoco.mj_kinematics(model, data)
            points[i], angles[i] = data.site_xpos[probe] * 1000, data.qpos[at]
        return points, angles

    # the stiffness that gives the drawn largest bend: the torque on the springs scales with k
    sag = rng.uniform(100, 300) * 1e-6
    _, trial = settle(1e9)
    k = 1e9 * np.hypot(*trial.T).max() / sag
    points, angles = settle(k)
    nearest = _joints_across(arm, values, tool, j)
    truth = {
        "name": "link_bending",
        "axis": "xyz",
        "nearest": "joint_compliance",
        "alike": ["joint_compliance"],
        "params": {
            "joint": nearest,  # a compliance on any of them is the nearest named effect
            "link": j + 1,
            "stiffness_nm_per_rad": float(k),
            "largest_bend_urad": float(np.hypot(*angles.T).max() * 1e6),
        },
    }
    return points, truth


def _joints_across(arm, values: np.ndarray, tool: np.ndarray, j: int) -> list[int]:
    """The joints (1-based) whose compliance looks like link j's (0-based) bend: the nearest on
    each side of the bend whose axis lies across the link (within 60 deg of square to it) at the
    arm's zero posture; a joint along the link would only twist it."""
    import mujoco

    from calibench.scenes.arm_mjcf import build_mjcf

    model = mujoco.MjModel.from_xml_string(build_mjcf(arm, values, tool))
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    u = data.xpos[model.body(f"link{j + 1}").id] - data.xpos[model.body(f"joint{j + 1}").id]
    u /= np.linalg.norm(u)
    across = [
        i + 1
        for i in range(arm.n_joints)
        if abs(data.xaxis[model.joint(f"q{i + 1}").id] @ u) < np.cos(np.deg2rad(30))
    ]
    inner = [i for i in across if i <= j + 1]
    outer = [i for i in across if i > j + 1]
    return ([inner[-1]] if inner else []) + ([outer[0]] if outer else [])


def pedestal_warmup_points(sim, q: np.ndarray, t_s: np.ndarray, rng: np.random.Generator):
    """The tool points (n, 3) mm, base frame, of the twin ``sim`` at postures ``q`` (n, N)
    read at ``t_s`` (n,), on a pedestal that the motors warm from power-on: the base rises by
    50-120 um (a 1 m steel pedestal warmed 4-10 K) as a first-order lag, time constant a third
    of the recording to all of it (an exponential in time: no candidate writes it; nearest
    ``thermal_drift``). Returns the points and the truth."""
    rise, tau = rng.uniform(50, 120) / 1000, rng.uniform(1 / 3, 1) * float(np.ptp(t_s))
    up = rise * (1 - np.exp(-(t_s - t_s[0]) / tau))
    truth = {"name": "pedestal_warmup", "axis": "xyz", "nearest": "thermal_drift"}
    params = {"rise_mm": rise, "tau_s": tau}
    return sim.probe_mm(q) + up[:, None] * np.array([0.0, 0.0, 1.0]), {**truth, "params": params}
