"""The rail's twin in MuJoCo: a screw's nut pulling a carriage through a belt.

The nut sits on a slide joint driven by a position actuator (the screw); its ``gear`` is
1 / (1 + scale), so the nut travels (1 + scale) times the command: the scale error. The carriage
sits on its own slide joint with ``frictionloss`` F against the world, coupled to the nut by a
fixed tendon of stiffness K (the belt). Moving, the carriage lags the nut by about F / K, so the
readings of one place approached from either side differ by about 2 F / K: lost motion. MuJoCo's
friction is a soft constraint and the carriage's inertia and the belt's damping act at every
stop, so the twin's lost motion is not 2 F / K exactly; whatever a report calls true is measured
on the twin itself (:func:`lost_motion_mm`, the noiseless traverse), never computed from F and K.

The friction's impedance is set close to 1 (``solimpfriction``): with MuJoCo's default the
carriage creeps under the belt's tension while it stands, and the lost motion is gone a tenth of
a second after each stop.
"""

from __future__ import annotations

import dataclasses

import numpy as np

TIMESTEP_S = 0.0005
MOVE_S = 0.6  # a move of the plan's 20 mm: slow enough that the carriage's inertia is small
SPEED_MM_S = 35.0  # longer moves of a replay keep this mean speed at most
SETTLE_S = 0.05  # standing still before the reading
CTRL_EVERY = 4  # steps between updates of the screw's command (its ramp, 2 ms apart)
NUT_KG, CARRIAGE_KG = 2.0, 0.2
SCREW_KP_N_PER_M = 2e6  # the screw's stiffness: ten times the belt's, it adds little lag

XML = """
<mujoco model="rail">
  <option timestep="{dt}" gravity="0 0 0" integrator="implicitfast"/>
  <worldbody>
    <body name="nut">
      <joint name="drive" type="slide" axis="1 0 0" damping="{nut_damping}"/>
      <geom type="box" size="0.01 0.01 0.01" mass="{nut_kg}" contype="0" conaffinity="0"/>
    </body>
    <body name="carriage">
      <joint name="carriage" type="slide" axis="1 0 0" frictionloss="{friction}"
             solimpfriction="0.999 0.9999 0.001" solreffriction="0.001 1"/>
      <geom type="box" size="0.03 0.02 0.01" mass="{carriage_kg}" contype="0" conaffinity="0"/>
    </body>
  </worldbody>
  <tendon>
    <fixed name="belt" stiffness="{stiffness}" damping="{belt_damping}">
      <joint joint="carriage" coef="1"/>
      <joint joint="drive" coef="-1"/>
    </fixed>
  </tendon>
  <actuator>
    <position name="screw" joint="drive" kp="{kp}" gear="{gear}"/>
  </actuator>
</mujoco>
"""


@dataclasses.dataclass(frozen=True)
class RailTruth:
    """The rail as built.

    Attributes
    ----------
    scale_ppm : float
        The screw's scale error: the nut travels (1 + scale_ppm 1e-6) times the command.
    friction_n : float
        The carriage's friction against the world, N (MuJoCo's ``frictionloss``).
    stiffness_n_per_m : float
        The belt's stiffness between the nut and the carriage, N/m.
    """

    scale_ppm: float = 50.0
    friction_n: float = 0.8
    stiffness_n_per_m: float = 2e5


class RailTwin:
    """The twin of ``truth``, at rest at the command 0, moved by :meth:`move`."""

    def __init__(self, truth: RailTruth):
        import mujoco

        k = truth.stiffness_n_per_m
        xml = XML.format(
            dt=TIMESTEP_S,
            nut_kg=NUT_KG,
            carriage_kg=CARRIAGE_KG,
            friction=truth.friction_n,
            stiffness=k,
            kp=SCREW_KP_N_PER_M,
            gear=1.0 / (1.0 + truth.scale_ppm * 1e-6),
            # both critically damped: a stop rings down before the reading
            nut_damping=2 * np.sqrt(SCREW_KP_N_PER_M * NUT_KG),
            belt_damping=2 * np.sqrt(k * CARRIAGE_KG),
        )
        self._mj = mujoco
        self.model = mujoco.MjModel.from_xml_string(xml)
        self.data = mujoco.MjData(self.model)
        self.command_mm = 0.0

    def move(self, target_mm: float) -> float:
        """Command the screw to ``target_mm`` along a cosine ramp, stand still, and return the
        carriage's position, mm (what a perfect interferometer reads)."""
        start, d = self.command_mm, self.data
        duration = max(MOVE_S, abs(target_mm - start) / SPEED_MM_S)
        n = max(1, int(round(duration / TIMESTEP_S / CTRL_EVERY)))
        for k in range(n):
            f = 0.5 - 0.5 * np.cos(np.pi * (k + 1) / n)
            d.ctrl[0] = (start + (target_mm - start) * f) / 1000.0
            self._mj.mj_step(self.model, d, nstep=CTRL_EVERY)
        self._mj.mj_step(self.model, d, nstep=int(round(SETTLE_S / TIMESTEP_S)))
        self.command_mm = float(target_mm)
        return float(d.qpos[1]) * 1000.0


def replay(truth: RailTruth, x_cmd_mm: np.ndarray, dir_x: np.ndarray, approach_mm: float):
    """The twin of ``truth`` moved to each command in turn, each approached from the side its
    direction says (a move the other way first goes ``approach_mm`` beyond the command).

    Parameters
    ----------
    truth : RailTruth
    x_cmd_mm : (n,) the commands in time order, mm.
    dir_x : (n,) +1 / -1, the direction of each command's approach.
    approach_mm : float
        How far beyond a command an approach from the other side starts, mm.

    Returns
    -------
    (n,) the carriage's positions at the readings, mm.
    """
    twin = RailTwin(truth)
    out = np.empty(len(x_cmd_mm))
    for i, (x, d) in enumerate(zip(x_cmd_mm, dir_x)):
        if np.sign(x - twin.command_mm) != d:  # arriving the other way, or not moving at all
            twin.move(x - d * approach_mm)
        out[i] = twin.move(x)
    return out


def plan(stations_mm: np.ndarray, passes: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The rail's recording plan: each pass forward over the stations, then backward.

    Returns
    -------
    x_cmd_mm, dir_x, run : (2 passes stations,) each, in time order.
    """
    s = np.asarray(stations_mm, float)
    one = np.r_[s, s[::-1]]
    dirs = np.r_[np.ones(len(s)), -np.ones(len(s))]
    runs = np.repeat(np.arange(passes), 2 * len(s))
    return np.tile(one, passes), np.tile(dirs, passes), runs.astype(float)


def lost_motion_mm(truth: RailTruth, at_mm: float, approach_mm: float) -> float:
    """The twin's own reversal at ``at_mm``: its reading approached forward minus approached
    backward, mm (negative: the carriage lags the screw)."""
    twin = RailTwin(truth)
    twin.move(at_mm - approach_mm)  # each reading approached over the plan's step
    forward = twin.move(at_mm)
    twin.move(at_mm + approach_mm)
    return forward - twin.move(at_mm)


def friction_for(reversal_mm: float, truth: RailTruth, at_mm: float, approach_mm: float) -> float:
    """The friction (N) at which the twin with ``truth``'s belt and scale shows the reversal
    ``reversal_mm`` at ``at_mm``: the secant method on the twin's own :func:`lost_motion_mm`,
    which grows with the friction nearly in proportion (from 2 F / K's guess, a few steps)."""
    want = abs(reversal_mm)

    def miss(f: float) -> float:
        shown = lost_motion_mm(dataclasses.replace(truth, friction_n=f), at_mm, approach_mm)
        return -shown - want

    f0 = want / 1000.0 * truth.stiffness_n_per_m / 2  # 2 F / K = B
    f1 = 1.2 * f0 + 1e-3
    m0, m1 = miss(f0), miss(f1)
    for _ in range(8):
        if m1 == m0 or abs(m1) < 1e-6 * max(want, 1e-6):
            break
        f0, f1 = f1, max(f1 - m1 * (f1 - f0) / (m1 - m0), 0.0)
        m0, m1 = m1, miss(f1)
    return float(f1)
