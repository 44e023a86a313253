"""Concealed effects whose mechanism is simulated, not written: the third suite's (issue 61).

The first two suites write their effects as formulas (the candidates' own, or others beside
them). Here MuJoCo's solver makes them: a joint limit's contact, friction loss, gravity and
inertia, stepped in time, and the error is whatever the simulation leaves. Each truth carries
the ``nearest`` candidate a discovery should name (and ``alike``: what the same mechanism also
looks like), as the second suite's do.

Arms:

- ``gear_play``: the most loaded joint's link turns through a gear with play: a hinge between
  the motor and the link whose range is the play (MuJoCo's joint limit: a contact that drags the
  link once the play is taken up) and whose friction holds the link where the move left it
  unless gravity's torque beats it. The arm moves from posture to posture in the recording's
  order (a smooth move, its fastest joint peaking at 1.5 rad/s, 0.25 s to settle) and the link
  rests where the solver puts it: lagging the motor by half the play after a move where friction
  holds it, on gravity's side where gravity wins. Nearest: ``backlash`` on that joint
  (``joint_compliance`` there is alike: the play taken up on gravity's side follows the
  torque's sign).
- ``encoder_slip``: once, between two postures, the arm runs a joint into its hard stop (a joint
  limit in MuJoCo, at 1-3 rad/s) and the encoder's disc, clamped to the shaft by friction, slips
  on it: its inertia carries it on while the stop halts the shaft, until the clamp's friction
  stops it. Every reading after is off by the slip the simulation leaves. Nearest: ``step`` on
  that joint, at that moment.
"""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np

SIMULATED_ARM_KINDS = ("gear_play", "encoder_slip")
MOVE_S, SETTLE_S = 0.5, 0.25  # the shortest move between postures and the rest after it
PEAK_RAD_S = 1.5  # the fastest joint's peak speed in a move (a UR10's shoulder: 2 rad/s at most)
STEP_S = 0.002  # the play's simulation step (its contact's time constant is twice it)
PLAY_URAD = (100.0, 300.0)  # half the gear's play, drawn
# the gear's friction, a share of the joint's largest gravity torque: held where the move left
# it at light loads, on gravity's side at heavy ones
FRICTION_SHARE = (0.8, 1.5)
SLIP_URAD = (150.0, 600.0)  # an encoder slip kept when the simulation leaves one in this range


def gear_play_angles(
    sim, q_motor: np.ndarray, rng: np.random.Generator
) -> tuple[np.ndarray, dict[str, Any]]:
    """The links' true angles (n, N) of a rigid twin ``sim`` (an ``ArmSim``) moved through the
    motor angles ``q_motor`` (n, N) in their order, its most loaded joint turning through a gear
    with play (the module's ``gear_play``), and the truth."""
    tau = sim.gravity_torques(q_motor)
    j = int(np.argmax(np.abs(tau).max(axis=0)))
    play = rng.uniform(*PLAY_URAD) * 1e-6
    friction = rng.uniform(*FRICTION_SHARE) * float(np.abs(tau[:, j]).max())
    m, d = sim.model, sim.data
    saved = (
        m.opt.timestep,
        m.jnt_limited[j],
        m.jnt_range[j].copy(),
        m.jnt_solref[j].copy(),
        m.jnt_solimp[j].copy(),
        m.dof_frictionloss[j],
        m.dof_damping[j],
        m.dof_solref[j].copy(),
        m.dof_solimp[j].copy(),
    )
    m.opt.timestep = STEP_S
    m.jnt_limited[j] = 1
    # the play's contacts as hard as the solver allows: the teeth's own give is another effect
    m.jnt_solref[j] = (2 * STEP_S, 1.0)
    m.jnt_solimp[j] = (0.9999, 0.9999, 0.001, 0.5, 2.0)
    m.dof_frictionloss[j] = friction
    # friction that holds, not a slow creep: MuJoCo's soft constraints creep at the default
    # impedance, over a play of a few hundred urad within the rest
    m.dof_solref[j] = (2 * STEP_S, 1.0)
    m.dof_solimp[j] = (0.9999, 0.9999, 0.001, 0.5, 2.0)
    m.dof_damping[j] = 0.05 * friction  # the gear's viscous loss: settles within SETTLE_S
    try:
        q_link = _moved_through(m, d, q_motor, j, play)
    finally:
        (m.opt.timestep, m.jnt_limited[j], m.jnt_range[j]) = saved[:3]
        m.jnt_solref[j], m.jnt_solimp[j] = saved[3:5]
        m.dof_frictionloss[j], m.dof_damping[j], m.dof_solref[j], m.dof_solimp[j] = saved[5:]
    truth = {
        "name": "gear_play",
        "axis": "xyz",
        "nearest": "backlash",
        "alike": ["joint_compliance"],
        "params": {
            "joint": j + 1,
            "play_urad": 2 * play * 1e6,
            "shown_urad": shown_play_urad(q_motor[:, j], q_link[:, j]),
            "friction_nm": friction,
        },
    }
    return q_link, truth


def shown_play_urad(q_motor: np.ndarray, q_link: np.ndarray) -> float:
    """The lost motion a joint's link shows (urad): its lag behind the motor ``q_link - q_motor``
    (n,) rad fitted, with an offset, to half a play in the direction the motor last turned. What
    ``backlash`` fitted to the link itself would give: the play less the contacts' give and what
    gravity takes up on its own side (the value the estimator's stated error is about)."""
    turned = np.sign(np.diff(q_motor, prepend=q_motor[0]))
    turned[turned == 0] = 1.0
    X = np.c_[np.ones_like(turned), turned / 2]
    coef, *_ = np.linalg.lstsq(X, (q_link - q_motor) * 1e6, rcond=None)
    return float(-coef[1])


def _moved_through(m, d, q_motor: np.ndarray, j: int, play: float) -> np.ndarray:
    """The link angles (n, N) at rest after each move of :func:`gear_play_angles`: the other
    joints follow their motors exactly, joint ``j``'s link is MuJoCo's (gravity, the play's
    contacts, friction), its range the play around its motor."""
    n_rest = int(SETTLE_S / STEP_S)
    others = np.arange(m.nv) != j
    out = np.empty_like(q_motor)
    d.qpos[:], d.qvel[:] = q_motor[0], 0.0
    mujoco.mj_forward(m, d)
    previous = q_motor[0]
    for i, target in enumerate(q_motor):
        step = target - previous
        # a smooth move at the arm's speed: its fastest joint peaks at PEAK_RAD_S
        duration = max(MOVE_S, 1.5 * float(np.abs(step).max()) / PEAK_RAD_S)
        n_move = int(duration / STEP_S)
        s = np.minimum(np.arange(1, n_move + n_rest + 1) / n_move, 1.0)
        shape, rate = 3 * s**2 - 2 * s**3, (6 * s - 6 * s**2) / duration
        for a, v in zip(shape, rate):  # the motors' path is prescribed: a loop in time
            m.jnt_range[j] = (previous[j] + a * step[j] - play, previous[j] + a * step[j] + play)
            d.qpos[others] = previous[others] + a * step[others]
            d.qvel[others] = v * step[others]
            mujoco.mj_step(m, d)
        out[i] = d.qpos
        out[i, others] = target[others]
        previous = target
    return out


def encoder_slip(
    t_s: np.ndarray, n_joints: int, rng: np.random.Generator
) -> tuple[np.ndarray, dict[str, Any]]:
    """The encoder readings' error (n, N) rad of an arm one of whose joints ran into its hard
    stop once (the module's ``encoder_slip``): zero before the moment, the slip MuJoCo leaves
    after, and the truth. The joint and the moment (between two readings, in the middle 60 % of
    the recording) are drawn; so are the shock's speed and the clamp, until the slip is in
    :data:`SLIP_URAD`."""
    n = len(t_s)
    j = int(rng.integers(1, min(n_joints, 3) + 1)) - 1  # the big joints, whose stops are hit
    k = int(rng.integers(int(0.2 * n), int(0.8 * n)))
    while True:
        speed = rng.uniform(1.0, 3.0)
        clamp_nm = rng.uniform(0.02, 0.2)
        slip = disc_slip(speed, clamp_nm)
        if SLIP_URAD[0] <= abs(slip) * 1e6 <= SLIP_URAD[1]:
            break
    off = np.zeros((n, n_joints))
    off[k:, j] = slip
    moment = 0.5 * (t_s[k - 1] + t_s[k])
    truth = {
        "name": "encoder_slip",
        "axis": "xyz",
        "nearest": "step",
        "params": {
            "joint": j + 1,
            "t_s": float(moment),
            "slip_urad": slip * 1e6,
            "speed_rad_s": speed,
            "clamp_nm": clamp_nm,
        },
    }
    return off, truth


DISC_INERTIA_KG_M2 = 2e-5  # an encoder's glass disc and hub
SHAFT_INERTIA_KG_M2 = 0.5


def disc_slip(speed: float, clamp_nm: float) -> float:
    """How far (rad) an encoder disc, clamped to its shaft by friction of ``clamp_nm``, slips
    when the shaft, turning at ``speed`` rad/s, hits its hard stop: MuJoCo's answer, the shaft a
    hinge with a limit, the disc a hinge on it with friction loss."""
    xml = f"""
    <mujoco>
      <option timestep="1e-5" gravity="0 0 0"/>
      <worldbody>
        <body name="shaft">
          <joint name="shaft" type="hinge" axis="0 0 1" limited="true" range="-1 0.01"
                 solreflimit="2e-5 1"/>
          <inertial pos="0 0 0" mass="1" diaginertia="1 1 {SHAFT_INERTIA_KG_M2}"/>
          <body name="disc">
            <joint name="disc" type="hinge" axis="0 0 1" frictionloss="{clamp_nm}"
                   solreffriction="2e-5 1"/>
            <inertial pos="0 0 0" mass="0.05" diaginertia="1e-5 1e-5 {DISC_INERTIA_KG_M2}"/>
          </body>
        </body>
      </worldbody>
    </mujoco>"""
    m = mujoco.MjModel.from_xml_string(xml)
    d = mujoco.MjData(m)
    d.qvel[:] = speed, 0.0
    for _ in range(int(0.05 / m.opt.timestep)):  # the stop is hit within 10 ms; then at rest
        mujoco.mj_step(m, d)
    return float(d.qpos[1])
