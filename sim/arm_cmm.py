"""The as-built arm CMM and its reference instruments.

Truth: the 25 parameter errors (default: the seed's Table 1) baked into the MJCF's body frames,
the tracker's pose relative to the arm's base, the reflector's place on the stylus, and the two
cones of a calibrated length bar. MuJoCo's kinematics give the true probe and reflector
positions for the true joint angles; the encoders read them with noise.

Instruments:
- a laser tracker: range (interferometer/ADM) and two angles of the reflector, each with its
  own noise (range: a + b * range; angles: urad);
- single-point articulation: the probe tip seated in a cone while the arm takes many postures
  (found by MuJoCo-Jacobian inverse kinematics from random starts), seating scatter in um;
- a length bar of calibrated length between two cones.
"""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np

from calibench.scenes.arm_cmm import ArmGeometry, build_mjcf

# The seed's Table 1 errors, in the estimators' order: (da, dd, dalpha, dtheta) of links 1-6
# (mm, mm, rad, rad), then dd7 (mm).
TABLE1_DELTA = (0.10, -0.05, 0.0010, 0.0014, -0.08, 0.11, 0.0014, -0.0023, -0.12, 0.06, -0.0012, 0.0017,
                0.03, 0.13, 0.0017, 0.0010, 0.07, -0.04, 0.0010, -0.0014, -0.14, 0.05, -0.0010, 0.0010, -0.03)


@dataclasses.dataclass(frozen=True)
class ArmTruth:
    delta: tuple = TABLE1_DELTA
    tracker_pos_mm: tuple = (2200.0, -900.0, 350.0)  # the tracker's head in the base frame
    tracker_yaw_rad: float = 2.75  # it faces the arm
    tracker_tilt_rad: tuple = (0.004, -0.003)
    # the reflector sits at the probe (an SMR in the probe's nest): the stylus parameters are
    # then the flange-to-reflector offset
    reflector_offset_mm: tuple = (0.0, 0.0, 0.0)
    cone_a_mm: tuple = (450.0, 250.0, -150.0)
    cone_b_mm: tuple = (450.0, -350.0, -150.0)  # 600 mm bar
    encoder_noise_urad: float = 5.0
    range_noise_um: tuple = (5.0, 1.0)  # a + b * range(m), 1-sigma
    angle_noise_urad: float = 4.0
    cone_seat_um: float = 2.0

    @property
    def bar_length_mm(self) -> float:
        return float(np.linalg.norm(np.subtract(self.cone_a_mm, self.cone_b_mm)))

    def tracker2base(self) -> tuple[np.ndarray, np.ndarray]:
        """The tracker frame in the base frame: R (3, 3), position (3,) mm."""
        cz, sz = np.cos(self.tracker_yaw_rad), np.sin(self.tracker_yaw_rad)
        Rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
        ax, ay = self.tracker_tilt_rad
        Rx = np.array([[1, 0, 0], [0, np.cos(ax), -np.sin(ax)], [0, np.sin(ax), np.cos(ax)]])
        Ry = np.array([[np.cos(ay), 0, np.sin(ay)], [0, 1, 0], [-np.sin(ay), 0, np.cos(ay)]])
        return Rz @ Ry @ Rx, np.asarray(self.tracker_pos_mm, float)


class ArmSim:
    def __init__(self, geometry: ArmGeometry, truth: ArmTruth):
        self.geometry, self.truth = geometry, truth
        e = np.asarray(truth.delta, float)
        per = e[:24].reshape(6, 4)
        a = np.asarray(geometry.a_mm) + np.r_[per[:, 0], 0.0]
        d = np.asarray(geometry.d_mm) + np.r_[per[:, 1], e[24]]
        alpha = np.asarray(geometry.alpha_rad) + np.r_[per[:, 2], 0.0]
        theta0 = np.r_[per[:, 3], 0.0]
        R, p = truth.tracker2base()
        q = np.empty(4)
        mujoco.mju_mat2Quat(q, R.ravel())
        xml = build_mjcf(geometry, a, d, alpha, theta0, truth.reflector_offset_mm, p / 1000, q,
                         (np.asarray(truth.cone_a_mm) / 1000, np.asarray(truth.cone_b_mm) / 1000))
        self.model = mujoco.MjModel.from_xml_string(xml)
        self.data = mujoco.MjData(self.model)
        self._probe = self.model.site("probe").id
        self._reflector = self.model.site("reflector").id
        self._jac = np.zeros((3, self.model.nv))

    # --- truth -----------------------------------------------------------------------------------
    def set_posture(self, q_rad: np.ndarray) -> None:
        self.data.qpos[:6] = q_rad
        mujoco.mj_kinematics(self.model, self.data)

    def probe_mm(self, q_rad: np.ndarray) -> np.ndarray:
        """True probe positions (base frame) for true joint angles (n, 6) -> (n, 3) mm."""
        return self._site_mm(np.atleast_2d(q_rad), self._probe)

    def reflector_mm(self, q_rad: np.ndarray) -> np.ndarray:
        return self._site_mm(np.atleast_2d(q_rad), self._reflector)

    def _site_mm(self, q, site):
        out = np.empty((len(q), 3))
        for i, qq in enumerate(q):
            self.set_posture(qq)
            out[i] = self.data.site_xpos[site] * 1000
        return out

    # --- postures and instruments ------------------------------------------------------------------
    def random_postures(self, n: int, rng: np.random.Generator, min_z_mm: float = -300.0) -> np.ndarray:
        """Postures within the joint limits whose probe stays above ``min_z_mm``, (n, 6)."""
        lim = np.array(self.geometry.joint_limits_rad)
        out = []
        while len(out) < n:
            q = rng.uniform(lim[:, 0], lim[:, 1], (n, 6))
            z = self.probe_mm(q)[:, 2]
            out.extend(q[z > min_z_mm])
        return np.array(out[:n])

    def postures_in_cone(self, cone_mm: np.ndarray, n: int, rng: np.random.Generator) -> np.ndarray:
        """n different true postures with the probe seated in the cone at ``cone_mm``: each
        seating puts the ball's centre ``cone_seat_um`` (1-sigma) off the cone's centre (inverse
        kinematics on MuJoCo's site Jacobian, damped least squares, from random starts)."""
        cone = np.asarray(cone_mm, float) / 1000
        lim = np.array(self.geometry.joint_limits_rad)
        out, tries = [], 0
        while len(out) < n:
            tries += 1
            if tries > 50 * n:
                raise ValueError(f"the cone at {cone_mm} mm is out of the arm's reach")
            q = rng.uniform(lim[:, 0], lim[:, 1])
            target = cone + rng.normal(0, self.truth.cone_seat_um * 1e-6, 3)
            for _ in range(100):
                self.set_posture(q)
                mujoco.mj_comPos(self.model, self.data)  # the Jacobian needs the dof axes
                err = target - self.data.site_xpos[self._probe]
                if np.linalg.norm(err) < 1e-12:
                    break
                mujoco.mj_jacSite(self.model, self.data, self._jac, None, self._probe)
                J = self._jac[:, :6]
                q = q + J.T @ np.linalg.solve(J @ J.T + 1e-6 * np.eye(3), err)
            if np.linalg.norm(err) < 1e-10:
                out.append((q + np.pi) % (2 * np.pi) - np.pi)
        return np.array(out)

    def encoders(self, q_true: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """What the joint encoders read, (n, 6) rad."""
        return q_true + rng.normal(0, self.truth.encoder_noise_urad * 1e-6, np.shape(q_true))

    def tracker(self, q_true: np.ndarray, rng: np.random.Generator | None) -> np.ndarray:
        """Range (mm), azimuth and elevation (rad) of the reflector, (n, 3); exact without rng."""
        R, p = self.truth.tracker2base()
        y = (self.reflector_mm(q_true) - p) @ R  # into the tracker frame
        rng_mm = np.linalg.norm(y, axis=1)
        a, b = self.truth.range_noise_um
        sph = np.stack([rng_mm, np.arctan2(y[:, 1], y[:, 0]), np.arcsin(y[:, 2] / rng_mm)], axis=1)
        if rng is None:
            return sph
        noise = np.stack([rng.normal(0, (a + b * rng_mm / 1000) / 1000),
                          rng.normal(0, self.truth.angle_noise_urad * 1e-6, len(y)),
                          rng.normal(0, self.truth.angle_noise_urad * 1e-6, len(y))], axis=1)
        return sph + noise

    def tracker_sigma(self, measured: np.ndarray) -> np.ndarray:
        """The tracker's stated 1-sigma of each measurement (range, az, el), (n, 3)."""
        a, b = self.truth.range_noise_um
        ang = np.full(len(measured), self.truth.angle_noise_urad * 1e-6)
        return np.stack([(a + b * measured[:, 0] / 1000) / 1000, ang, ang], axis=1)

    def base2tracker(self) -> tuple[np.ndarray, np.ndarray]:
        R, p = self.truth.tracker2base()
        return R.T, -R.T @ p
