"""What a stage axis's drive adds to its commanded position, beyond the scene's error map.

Two parts, both switched off by default (the geometry-only twin):

- ``DriveErrors``: lost motion on reversal (constant, or growing along the travel), a periodic
  error in the axis's own position (a pulley's or screw's run-out) and thermal expansion of the
  scale with the room's temperature. ``discover --twin`` writes what it found in these terms.
- ``ElasticBelt``: the belt stage's timing belt as two elastic tendons (the tight span from the
  drive pulley to the carriage, the return span round the idler) against the carriage's dry
  friction. MuJoCo gives the spans' lengths and the spring force; the carriage rests where that
  force no longer beats friction, short of the command by force over stiffness. The tight span
  lengthens along the travel, so the lost motion grows with the position.

Units: positions mm along the axis from home, forces N, EA (the belt's axial rigidity) N.
"""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np


def travel_direction(before: np.ndarray, after: np.ndarray, last: np.ndarray) -> np.ndarray:
    """Each axis's direction of travel (+1 or -1) for a move from ``before`` to ``after`` (k,);
    an axis that does not move keeps its ``last`` direction. Plain floats: a move's few axes
    cost less in Python than in numpy calls."""
    return np.array(
        [
            1.0 if b > a else -1.0 if b < a else d
            for a, b, d in zip(before.tolist(), after.tolist(), last.tolist())
        ]
    )


def travel_directions(before: np.ndarray, path: np.ndarray, last: np.ndarray) -> np.ndarray:
    """:func:`travel_direction` along a path of moves: from ``before`` (k,) through the targets
    ``path`` (m, k) in order, each axis's direction (m, k) of the move that ends at each target.
    A loop of plain floats: most paths are a move or two."""
    prev, d, out = np.asarray(before, float).tolist(), np.asarray(last, float).tolist(), []
    for p in np.asarray(path, float).tolist():
        d = [1.0 if b > a else -1.0 if b < a else x for a, b, x in zip(prev, p, d)]
        out.append(d)
        prev = p
    return np.array(out)


@dataclasses.dataclass(frozen=True)
class DriveErrors:
    """One axis's drive errors (all zero: a perfect drive).

    reversal_at_home_um : lost motion at home (u = 0): the position approached forward less the
        one approached backward (negative: the carriage stops short of its command).
    reversal_growth_um_per_m : its growth per metre of travel (an elastic drive's).
    periodic_um, period_mm, periodic_phase_rad : ``A sin(2 pi u / P + phase)``.
    thermal_ppm_per_k, reference_temp_c : the scale's expansion, ``k (T - T_ref) u``.
    """

    reversal_at_home_um: float = 0.0
    reversal_growth_um_per_m: float = 0.0
    periodic_um: float = 0.0
    period_mm: float = 0.0
    periodic_phase_rad: float = 0.0
    thermal_ppm_per_k: float = 0.0
    reference_temp_c: float = 20.0

    def __post_init__(self):
        # a period of zero would silently drop the periodic error; the bounds are beyond any
        # drive (a lost motion or ripple of 10 mm, a scale of 1000 ppm/K) and any workshop
        if self.periodic_um and not self.period_mm > 0:
            raise ValueError(f"period_mm = {self.period_mm}: a periodic error needs a period > 0")
        for name in ("reversal_at_home_um", "reversal_growth_um_per_m", "periodic_um"):
            if abs(getattr(self, name)) > 1e4:
                raise ValueError(f"{name} = {getattr(self, name)}: at most 1e4 um (10 mm)")
        if abs(self.thermal_ppm_per_k) > 1000:
            raise ValueError(f"thermal_ppm_per_k = {self.thermal_ppm_per_k}: at most 1000")
        if not -100 <= self.reference_temp_c <= 200:
            raise ValueError(
                f"reference_temp_c = {self.reference_temp_c}: a workshop's, -100 to 200 deg C"
            )

    @property
    def perfect(self) -> bool:
        """No error at all (every move can skip it)."""
        return not (
            self.reversal_at_home_um
            or self.reversal_growth_um_per_m
            or self.periodic_um
            or self.thermal_ppm_per_k
        )

    def error_mm(
        self, u_mm: np.ndarray, direction: np.ndarray, temp_c: np.ndarray | None = None
    ) -> np.ndarray:
        """The drive's error at commanded positions ``u_mm`` (n,), approached in ``direction``
        (n,) of +1 / -1, at room temperatures ``temp_c`` (n,) (None: the reference): (n,) mm."""
        u = np.asarray(u_mm, float)
        e = (
            np.asarray(direction, float)
            / 2
            * (self.reversal_at_home_um + self.reversal_growth_um_per_m * u / 1000)
            / 1000
        )
        if self.periodic_um and self.period_mm > 0:
            e = e + self.periodic_um / 1000 * np.sin(
                2 * np.pi * u / self.period_mm + self.periodic_phase_rad
            )
        if self.thermal_ppm_per_k and temp_c is not None:
            e = (
                e
                + self.thermal_ppm_per_k
                * 1e-6
                * (np.asarray(temp_c, float) - self.reference_temp_c)
                * u
            )
        return e


@dataclasses.dataclass(frozen=True)
class BeltDrive:
    """An axis's belt and carriage. ``ea_n`` 0: a rigid belt (no elastic lag).

    ea_n : the belt's axial rigidity E A (a 6 mm glass-fibre GT2 belt: about 30-60 kN).
    friction_n : the carriage's dry friction on its rail.
    overhang_mm : from each end of the travel to the pulley's axis.
    pulley_radius_mm : the drive and idler pulleys' pitch radius.
    carriage_kg : the moving mass (sets only how fast it settles, not where).
    """

    ea_n: float = 0.0
    friction_n: float = 0.0
    overhang_mm: float = 40.0
    pulley_radius_mm: float = 6.4
    carriage_kg: float = 0.8


class ElasticBelt:
    """One belt-driven axis in MuJoCo: where the carriage rests for each command.

    The carriage is a slide joint; the belt's two free spans are spatial tendons whose
    rest lengths are what the drive pulley has paid out for the command, and whose stiffness is
    EA over that length. The carriage is stepped (critically damped, friction against its
    motion) until it stops; a spring force within the friction leaves it where it is (stiction).
    """

    def __init__(self, travel_mm: float, drive: BeltDrive):
        if drive.ea_n <= 0:
            raise ValueError("an elastic belt needs EA > 0")
        self.drive = drive
        a, r, T = drive.overhang_mm / 1000, drive.pulley_radius_mm / 1000, travel_mm / 1000
        xml = f"""
<mujoco model="belt_axis">
  <option timestep="2e-4" gravity="0 0 0"/>
  <worldbody>
    <site name="drive_top" pos="{-a} 0 {r}"/>
    <site name="drive_bottom" pos="{-a} 0 {-r}"/>
    <site name="idler_top" pos="{T + a} 0 {r}"/>
    <site name="idler_bottom" pos="{T + a} 0 {-r}"/>
    <body name="carriage">
      <joint name="u" type="slide" axis="1 0 0"/>
      <geom type="box" size="0.02 0.02 0.01" mass="{drive.carriage_kg}"/>
      <site name="clamp" pos="0 0 {r}"/>
    </body>
  </worldbody>
  <tendon>
    <spatial name="tight"><site site="drive_top"/><site site="clamp"/></spatial>
    <spatial name="return"><site site="clamp"/><site site="idler_top"/><site site="idler_bottom"/>
      <site site="drive_bottom"/></spatial>
  </tendon>
</mujoco>"""
        self.model = mujoco.MjModel.from_xml_string(xml)
        self.data = mujoco.MjData(self.model)
        self.u_mm = 0.0
        self._command = None

    def _spans_at(self, u_mm: float) -> np.ndarray:
        """The two free spans' lengths (2,) m with the carriage at ``u_mm``, from MuJoCo's
        tendons."""
        self.data.qpos[0] = u_mm / 1000
        mujoco.mj_kinematics(self.model, self.data)
        mujoco.mj_tendon(self.model, self.data)
        return self.data.ten_length.copy()

    def _spring_n(self, u_mm: float) -> float:
        """The belt's net force on the carriage at ``u_mm`` (N, + towards +u): MuJoCo's
        passive force."""
        self.data.qpos[0], self.data.qvel[0] = u_mm / 1000, 0.0
        mujoco.mj_forward(self.model, self.data)
        return float(self.data.qfrc_passive[0])

    def move(self, command_mm: float) -> float:
        """Drive the pulley to ``command_mm``; returns where the carriage rests (mm)."""
        m = self.model
        rest = self._spans_at(command_mm)
        m.tendon_lengthspring[:] = rest[:, None]  # no net pull with the carriage at the command
        m.tendon_stiffness[:] = self.drive.ea_n / rest
        f = self._spring_n(self.u_mm)
        F = self.drive.friction_n
        if abs(f) <= F:  # within friction: the carriage does not move
            return self.u_mm
        k = float(np.sum(m.tendon_stiffness))
        # heavily overdamped (4x critical): the carriage creeps up to its rest point from behind, as
        # one driven slowly does, and never overshoots (where friction would hold it wrongly)
        m.dof_damping[0] = 8 * np.sqrt(k * self.drive.carriage_kg)
        sign = np.sign(f)
        d = self.data
        d.qpos[0], d.qvel[0] = self.u_mm / 1000, 0.0
        d.qfrc_applied[0] = -sign * F  # kinetic friction against the motion
        for _ in range(200_000):
            mujoco.mj_step(m, d)
            if d.qvel[0] * sign < 1e-12:
                break
        else:
            raise RuntimeError("the carriage did not come to rest")
        d.qfrc_applied[0] = 0.0
        self.u_mm = float(d.qpos[0] * 1000)
        return self.u_mm
