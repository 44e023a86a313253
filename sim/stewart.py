"""The as-built Stewart platform and the tracker's interferometric lengths.

Truth: base hinges, platform hinges and initial leg lengths off their nominal values (drawn
from the run's seed, about 0.1-1 mm), the tracker's rotation centre in each hole of the plate.
A pose is set in MuJoCo from closed-form inverse kinematics (universal-joint angles, slide,
platform free joint), and the loop closure is measured, not assumed.
"""

from __future__ import annotations

import dataclasses
import math

import mujoco
import numpy as np

from calibench.scenes.stewart import StewartGeometry, build_mjcf
from calibench.sim.stage_drive import travel_direction


@dataclasses.dataclass(frozen=True)
class StewartTruth:
    hinge_error_mm: float = 0.4  # 1-sigma, each coordinate of each hinge
    length_error_mm: float = 0.5  # 1-sigma, each initial length
    station_offset_mm: float = 0.5  # 1-sigma: where the tracker's centre sits in a hole
    length_noise_um: tuple = (0.3, 0.3)  # interferometer: a + b * L(m), 1-sigma
    reading_noise_um: float = 1.0  # the legs' length readings
    # The legs' physics beyond rigid kinematics (all zero: the geometry-only twin), per leg:
    # compliance (the leg gives c um per N of the axial force MuJoCo's statics put on it, so its
    # screw reads that much more), thermal growth about reference_temp_c, lost motion on
    # reversal, and the screw's periodic pitch error A sin(2 pi L / lead + phase).
    leg_compliance_um_per_n: tuple = (0.0,) * 6
    payload_n: float = 0.0  # hanging at the platform's centre
    leg_thermal_ppm_per_k: tuple = (0.0,) * 6
    reference_temp_c: float = 20.0
    leg_reversal_um: tuple = (0.0,) * 6
    leg_pitch_um: tuple = (0.0,) * 6
    leg_pitch_lead_mm: tuple = (0.0,) * 6
    leg_pitch_phase_rad: tuple = (0.0,) * 6

    def __post_init__(self):
        pitched = (np.asarray(self.leg_pitch_um, float) != 0) & ~(
            np.asarray(self.leg_pitch_lead_mm, float) > 0
        )
        if pitched.any():  # leg_effects_mm would leave the error out without a word
            raise ValueError(
                f"leg {int(np.argmax(pitched)) + 1} has a pitch error (leg_pitch_um) but no screw "
                "lead: leg_pitch_lead_mm must be positive there"
            )

    @property
    def has_leg_physics(self) -> bool:
        """Whether any leg effect is switched on."""
        return any(
            np.any(np.asarray(v) != 0)
            for v in (
                self.leg_compliance_um_per_n,
                self.leg_thermal_ppm_per_k,
                self.leg_reversal_um,
                self.leg_pitch_um,
            )
        )


def leg_effects_mm(
    truth: StewartTruth,
    L_mm: np.ndarray,
    force_n: np.ndarray | None,
    direction: np.ndarray | None,
    temp_c: np.ndarray | None,
) -> np.ndarray:
    """What the legs' readings carry beyond ``L - l0``, (n, 6) mm, at true lengths ``L_mm``
    (n, 6), axial forces ``force_n`` (n, 6) N (positive: compression), the drives' last motion
    ``direction`` (n, 6) of +1 / -1 and the room's ``temp_c`` (n,); a None driver leaves its
    effect out."""
    L = np.atleast_2d(np.asarray(L_mm, float))
    out = np.zeros_like(L)
    if force_n is not None:
        out += np.asarray(truth.leg_compliance_um_per_n) * 1e-3 * np.atleast_2d(force_n)
    if temp_c is not None:  # the leg grows: the screw reads less for the same hinge distance
        dT = np.asarray(temp_c, float).reshape(-1, 1) - truth.reference_temp_c
        out -= np.asarray(truth.leg_thermal_ppm_per_k) * 1e-6 * dT * L
    if direction is not None:
        out += np.asarray(truth.leg_reversal_um) / 2000 * np.atleast_2d(direction)
    lead = np.asarray(truth.leg_pitch_lead_mm, float)
    on = (np.asarray(truth.leg_pitch_um) != 0) & (lead > 0)
    if on.any():
        ph = 2 * np.pi * L[:, on] / lead[on] + np.asarray(truth.leg_pitch_phase_rad)[on]
        out[:, on] += np.asarray(truth.leg_pitch_um)[on] / 1000 * np.sin(ph)
    return out


class StewartSim:
    """The platform's twin: six legs between ball joints, the truth's hinge errors, a tracker's
    reflectors on the platform."""

    def __init__(self, geometry: StewartGeometry, truth: StewartTruth, rng: np.random.Generator):
        g = geometry
        self.geometry, self.truth, self.rng = g, truth, rng
        self.B = g.base_hinges_mm + rng.normal(0, truth.hinge_error_mm, (6, 3))
        self.r = g.platform_hinges_mm + rng.normal(0, truth.hinge_error_mm, (6, 3))
        self.l0 = g.initial_lengths_mm + rng.normal(0, truth.length_error_mm, 6)
        self.stations = g.station_holes_mm + rng.normal(0, truth.station_offset_mm, (3, 3))
        self.model = mujoco.MjModel.from_xml_string(
            build_mjcf(g, self.B, self.r, g.reflectors_mm, self.stations)
        )
        self.data = mujoco.MjData(self.model)
        m = self.model
        self._ux = [m.jnt_qposadr[m.joint(f"leg{i}_ux").id] for i in range(6)]
        self._uy = [m.jnt_qposadr[m.joint(f"leg{i}_uy").id] for i in range(6)]
        self._slide = [m.jnt_qposadr[m.joint(f"leg{i}_slide").id] for i in range(6)]
        self._slide_dof = [m.jnt_dofadr[m.joint(f"leg{i}_slide").id] for i in range(6)]
        self._free = m.jnt_qposadr[m.joint("platform").id]
        self._ends = [m.site(f"leg{i}_end").id for i in range(6)]
        self._plat = [m.site(f"plat{i}").id for i in range(6)]
        self._refl = [m.site(f"reflector{k}").id for k in range(3)]
        self.max_closure_um = 0.0
        self._pose = (np.eye(3), np.array([0.0, 0.0, g.home_height_mm]))
        self._last_L: np.ndarray | None = None
        self._dir = np.ones(6)

    def set_pose(self, R: np.ndarray, t_mm: np.ndarray) -> None:
        """Put the platform at pose (R, t) and every leg where it must be; record loop closure."""
        q = self.data.qpos
        self._pose = (np.array(R, float), np.array(t_mm, float))
        q[self._free : self._free + 3] = np.asarray(t_mm) / 1000
        quat = np.empty(4)
        mujoco.mju_mat2Quat(quat, np.asarray(R, float).ravel())
        q[self._free + 3 : self._free + 7] = quat
        v = self.r @ R.T + t_mm - self.B
        L = np.linalg.norm(v, axis=1)
        u = v / L[:, None]
        # Rx(a) Ry(b) e_z = (sin b, -sin a cos b, cos a cos b) = u
        q[self._uy] = np.arcsin(u[:, 0])
        q[self._ux] = np.arctan2(-u[:, 1], u[:, 2])
        q[self._slide] = L / 1000
        mujoco.mj_kinematics(self.model, self.data)
        xpos = self.data.site_xpos
        gap = np.max(np.linalg.norm(xpos[self._ends] - xpos[self._plat], axis=1))
        self.max_closure_um = max(self.max_closure_um, float(gap) * 1e6)

    def leg_lengths_mm(self) -> np.ndarray:
        """True hinge-to-hinge lengths from MuJoCo's state (the slides)."""
        return self.data.qpos[self._slide] * 1000

    def readings_mm(self, temp_c: float | None = None) -> np.ndarray:
        """What the legs' length sensors read: length - initial length, noisy, with the truth's
        leg physics (compliance under MuJoCo's statics at the current pose and payload, lost
        motion by each drive's last direction, thermal growth at the room's ``temp_c``)."""
        L = self.leg_lengths_mm()
        out = L - self.l0 + self.rng.normal(0, self.truth.reading_noise_um / 1000, 6)
        if self.truth.has_leg_physics:
            before = self._last_L if self._last_L is not None else L - 1.0  # homed from below
            self._dir = travel_direction(before, L, self._dir)
            self._last_L = L
            force = (
                self.leg_forces_n(*self._pose, self.truth.payload_n)
                if np.any(np.asarray(self.truth.leg_compliance_um_per_n) != 0)
                else None
            )
            out += leg_effects_mm(
                self.truth, L, force, self._dir, None if temp_c is None else np.array([temp_c])
            )[0]
        return out

    def reflectors_mm(self) -> np.ndarray:
        """The reflectors' positions in the world, (k, 3) mm, at the current pose."""
        return self.data.site_xpos[self._refl] * 1000

    def length_sigma_mm(self, L_mm) -> np.ndarray:
        """The tracker's 1-sigma (mm) for distances ``L_mm``: a + b L, a in um and b in um per m
        (truth.length_noise_um)."""
        a, b = self.truth.length_noise_um
        return (a + b * np.asarray(L_mm) / 1000) / 1000

    def distances_mm(self, station: int, points_mm: np.ndarray) -> np.ndarray:
        """The tracker's interferometric lengths from its centre in hole ``station``."""
        L = np.linalg.norm(np.asarray(points_mm) - self.stations[station], axis=1)
        return L + self.rng.normal(0, self.length_sigma_mm(L))

    def distances_many_mm(self, points_mm: np.ndarray) -> np.ndarray:
        """The tracker's lengths (k, 3) from each of the three stations to each of k points, the
        noise drawn in the order k, then station (as k x 3 calls of :meth:`distances_mm` would)."""
        L = np.linalg.norm(np.asarray(points_mm)[:, None, :] - self.stations[None, :3], axis=2)
        return L + self.rng.normal(0, self.length_sigma_mm(L))

    def leg_forces_n(self, R: np.ndarray, t_mm: np.ndarray, load_n: float = 0.0) -> np.ndarray:
        """The legs' axial forces (6,) N (positive: the leg pushes, it is in compression) that hold
        the platform still at pose (R, t) under gravity and a load of ``load_n`` N hanging at the
        platform's centre: MuJoCo's statics.

        With the velocities zero, inverse dynamics at zero acceleration gives the generalised
        forces gravity asks for (``qfrc_bias``); the legs' slide forces f and the spherical joints'
        constraint forces lam (the ``connect`` equalities' Jacobian, from MuJoCo) must supply them:
        S^T f + J_c^T lam = qfrc_bias - qfrc_load, 24 equations in 24 unknowns."""
        m, d = self.model, self.data
        self.set_pose(R, t_mm)
        d.qvel[:] = 0.0
        d.qacc[:] = 0.0
        mujoco.mj_forward(m, d)
        mujoco.mj_inverse(m, d)  # qfrc_bias: gravity's generalised forces at rest
        need = d.qfrc_bias.copy()
        if load_n:
            ext = np.zeros(m.nv)
            body = m.body("platform").id
            mujoco.mj_applyFT(
                m, d, np.array([0.0, 0.0, -float(load_n)]), np.zeros(3), d.xpos[body], body, ext
            )
            need -= ext
        eq = d.efc_type == mujoco.mjtConstraint.mjCNSTR_EQUALITY
        Jc = d.efc_J.reshape(d.nefc, m.nv)[eq] if not mujoco.mj_isSparse(m) else None
        if Jc is None:
            raise RuntimeError("the platform's model uses a sparse constraint Jacobian")
        S = np.zeros((6, m.nv))
        S[np.arange(6), self._slide_dof] = 1.0
        A = np.vstack([S, Jc]).T  # (nv, 6 + 18)
        sol = np.linalg.solve(A, need)
        return sol[:6]

    def platform_hinges_world_mm(self) -> np.ndarray:
        """The true platform hinges in the world, (6, 3) mm, at the current pose."""
        return np.array([self.data.site_xpos[s] for s in self._plat]) * 1000


def stewart_poses(
    n: int,
    rng: np.random.Generator,
    geometry,
    translation_mm: float,
    rotation_deg: float,
) -> list[tuple[np.ndarray, np.ndarray]]:
    """Random poses of a Stewart platform within a working range about its home.

    Parameters
    ----------
    n : int
        How many poses.
    rng : numpy.random.Generator
        The draws, per pose a rotation vector then a translation.
    geometry : calibench.scenes.stewart.StewartGeometry
        The machine; its ``home_height_mm`` is the home's height.
    translation_mm : float
        Each coordinate of the origin drawn uniformly within home +- this, mm.
    rotation_deg : float
        Each component of the rotation vector drawn uniformly within +- this, deg.

    Returns
    -------
    list of (ndarray, ndarray)
        ``n`` poses: R (3, 3) the platform's orientation and t (3,) its origin, mm.
    """
    home = np.array([0, 0, geometry.home_height_mm])
    rot = np.deg2rad(rotation_deg)
    return [
        (
            _rotvec_to_matrix(rng.uniform(-rot, rot, 3)),
            home + rng.uniform(-1, 1, 3) * translation_mm,
        )
        for _ in range(n)
    ]


def _rotvec_to_matrix(w: np.ndarray) -> np.ndarray:
    """Rotation vector (3,) rad -> matrix (3, 3) by Rodrigues' formula on scalars: sim's own (sim
    never imports the estimators), in the floating-point operations the platform's poses have
    always been drawn with (every study and recording depends on their last bits)."""
    x, y, z = (float(v) for v in w)
    theta = math.sqrt(x * x + y * y + z * z)
    small = theta < 1e-8
    a = 1.0 - theta**2 / 6 if small else math.sin(theta) / theta
    b = 0.5 - theta**2 / 24 if small else 2 * (math.sin(0.5 * theta) / theta) ** 2
    xx, yy, zz = x * x, y * y, z * z
    ax, ay, az = a * x, a * y, a * z
    bxy, bxz, byz = b * x * y, b * x * z, b * y * z
    rows = (
        (1 - b * (yy + zz), bxy - az, bxz + ay),
        (bxy + az, 1 - b * (xx + zz), byz - ax),
        (bxz - ay, byz + ax, 1 - b * (xx + yy)),
    )
    return np.array(rows)
