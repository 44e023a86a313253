"""The as-built frame tracer: the rail's true (d, dL, alpha0), the plate's placement, the probe.

A reading is MuJoCo's ray from the stylus's start point Q along the rail against the walls of
one part (``mj_ray``), at the turntable's true angle; the probe then adds its noise and the
linear encoder quantises. The table's angle at a sample is the encoder's nominal angle plus a
small jitter (the sampling's timing).
"""

from __future__ import annotations

import copy
import dataclasses
import functools

import mujoco
import numpy as np

from calibench.scenes.probe_scanner import (
    LENS_GROUP,
    PLATE_GROUP,
    ProbeScannerGeometry,
    as_built_model,
    walls_mjcf,
)

N_SECTORS = 24  # ray directions per 15 degrees


@dataclasses.dataclass(frozen=True)
class ProbeScannerTruth:
    d_mm: float = 8.0
    dL_mm: float = 3.0
    alpha0_rad: float = 0.35
    plate_centre_mm: tuple[float, float] = (0.12, -0.08)  # the plate as clamped in the holder
    probe_noise_um: float = 2.0  # 1-sigma, before quantisation
    quantum_um: float = 5.0  # the linear encoder's step
    angle_jitter_deg: float = 0.003  # 1-sigma
    # What discover found and ``discover --twin`` writes (none by default): the table's radial
    # error motion along the rail as whole harmonics per turn, the reading longer by
    # sum A_k sin(k theta + phase_k); the encoder's disc off-centre, reading A sin(theta + phase)
    # ahead of the table; the probe's scale.
    runout_harmonics: tuple = ()
    runout_mm: tuple = ()
    runout_phase_rad: tuple = ()
    encoder_eccentricity_urad: float = 0.0
    encoder_eccentricity_phase_rad: float = 0.0
    probe_scale_ppm: float = 0.0

    def __post_init__(self):
        if not len(self.runout_harmonics) == len(self.runout_mm) == len(self.runout_phase_rad):
            raise ValueError(
                "runout_harmonics, runout_mm and runout_phase_rad need one value each per harmonic"
            )
        if any(not (float(k).is_integer() and k >= 1) for k in self.runout_harmonics):
            raise ValueError(
                f"runout_harmonics = {list(self.runout_harmonics)}: a run-out repeats a whole "
                "number of times per turn, 1 or more"
            )


@dataclasses.dataclass
class Scan:
    """One turn of the tracer: encoder angles (n,) rad and readings (n,) mm."""

    theta_rad: np.ndarray
    rho_mm: np.ndarray


class ProbeScannerSim:
    """The scanner's twin: a rotary table, a rail and a spring-loaded stylus whose contact is
    MuJoCo's ray cast."""

    def __init__(self, geometry: ProbeScannerGeometry, truth: ProbeScannerTruth):
        self.geometry, self.truth = geometry, truth
        self.model = as_built_model(
            geometry, truth.d_mm, truth.dL_mm, truth.alpha0_rad, truth.plate_centre_mm
        )
        self.data = mujoco.MjData(self.model)
        self._theta = self.model.jnt_qposadr[self.model.joint("theta").id]
        self._q = self.model.site("Q").id
        self._dir = self.model.site("rail_dir").id
        self._geomid = np.zeros(1, np.int32)
        self._ray_cache: dict[str, tuple[mujoco.MjModel, mujoco.MjData, list[np.ndarray]]] = {}

    def turn_to(self, theta_rad: float) -> None:
        """Turn the table to ``theta_rad`` and update the kinematics."""
        self.data.qpos[self._theta] = theta_rad
        mujoco.mj_kinematics(self.model, self.data)

    def ray_mm(self, part: str) -> float:
        """Exact distance from Q along the rail to ``part``'s wall at the current angle, mm."""
        group = np.zeros(6, np.uint8)
        group[PLATE_GROUP if part == "plate" else LENS_GROUP] = 1
        q = self.data.site_xpos[self._q]
        u = self.data.site_xpos[self._dir] - q
        u /= np.linalg.norm(u)
        dist = mujoco.mj_ray(self.model, self.data, q, u, group, 1, -1, self._geomid)
        if dist < 0:
            raise RuntimeError(
                f"the stylus found no wall of the {part} at angle {self.data.qpos[self._theta]:.4f}"
            )
        return dist * 1000

    def exact_rho(self, part: str, theta_rad: np.ndarray) -> np.ndarray:
        """Noise-free readings at true table angles (n,) -> (n,) mm.

        The rail rides the table, the parts stand still: the stylus's start Q and direction at
        each angle are MuJoCo's at angle 0 turned about the joint's axis, so only the ray casts
        run per sample (the same rays as :meth:`turn_to` then :meth:`ray_mm`, to 1e-12 mm). Each
        ray is cast in a model of the part's walls alone, against those its direction can reach
        (:func:`ray_sectors`), the others hidden meanwhile: the same nearest wall and the same
        distance as a cast in the whole twin, in a fraction of the time."""
        from scipy.spatial.transform import Rotation

        self.turn_to(0.0)
        j = self.model.joint("theta").id
        c, axis = self.data.xanchor[j].copy(), self.data.xaxis[j].copy()
        q0 = self.data.site_xpos[self._q] - c
        u0 = self.data.site_xpos[self._dir] - self.data.site_xpos[self._q]
        R = Rotation.from_rotvec(np.outer(np.asarray(theta_rad, float), axis)).as_matrix()
        q = c + R @ q0
        u = R @ (u0 / np.linalg.norm(u0))
        model, data, sectors = self._rays(part)
        group = np.zeros(6, np.uint8)
        group[PLATE_GROUP if part == "plate" else LENS_GROUP] = 1
        out = np.empty(len(q))
        sector = np.floor(
            (np.arctan2(u[:, 1], u[:, 0]) + np.pi) / (2 * np.pi) * len(sectors)
        ).astype(int) % len(sectors)
        # mj_ray skips an invisible geom (no material, alpha 0) at its second test: a sector's
        # out-of-reach walls are hidden while its rays are cast
        matid, alpha = model.geom_matid.copy(), model.geom_rgba[:, 3].copy()
        try:
            for k in np.unique(sector):
                model.geom_matid[:], model.geom_rgba[:, 3] = -1, 0.0
                model.geom_matid[sectors[k]] = matid[sectors[k]]
                rays = np.flatnonzero(sector == k)
                out[rays] = [
                    mujoco.mj_ray(model, data, qi, ui, group, 1, -1, self._geomid)
                    for qi, ui in zip(q[rays], u[rays])
                ]
        finally:
            model.geom_matid[:], model.geom_rgba[:, 3] = matid, alpha
        if np.any(out < 0):
            th = float(np.asarray(theta_rad)[np.argmax(out < 0)])
            raise RuntimeError(f"the stylus found no wall of the {part} at angle {th:.4f}")
        return out * 1000

    def _rays(self, part: str) -> tuple[mujoco.MjModel, mujoco.MjData, list[np.ndarray]]:
        """The part's walls alone (its own model, placed as in the twin: the same geom poses to
        the bit, checked) and, per direction sector, the walls a ray can reach (computed once)."""
        if part not in self._ray_cache:
            model = copy.copy(_walls_model(self.geometry, part))
            for body in ("holder", part):
                model.body_pos[model.body(body).id] = self.model.body_pos[self.model.body(body).id]
                model.body_quat[model.body(body).id] = self.model.body_quat[
                    self.model.body(body).id
                ]
            data = mujoco.MjData(model)
            mujoco.mj_kinematics(model, data)
            walls = np.flatnonzero(
                self.model.geom_group == (PLATE_GROUP if part == "plate" else LENS_GROUP)
            )
            if not (
                np.array_equal(data.geom_xpos, self.data.geom_xpos[walls])
                and np.array_equal(data.geom_xmat, self.data.geom_xmat[walls])
            ):
                raise RuntimeError(
                    f"the {part}'s ray model does not place its walls as the twin does"
                )
            self.turn_to(0.0)
            j = self.model.joint("theta").id
            axis_xy = self.data.xanchor[j][:2]
            q0 = self.data.site_xpos[self._q] - self.data.xanchor[j]
            u0 = self.data.site_xpos[self._dir] - self.data.site_xpos[self._q]
            corners = (
                box_corners_xy(data.geom_xpos, data.geom_xmat.reshape(-1, 3, 3), model.geom_size)
                - axis_xy
            )
            if np.allclose(self.data.xaxis[j], [0, 0, 1], rtol=0, atol=1e-12) and abs(
                u0[2]
            ) < 1e-12 * np.linalg.norm(u0):
                sectors = [
                    np.flatnonzero(m)
                    for m in ray_sectors(corners, q0[:2], u0[:2] / np.linalg.norm(u0[:2]))
                ]
            else:  # rays out of the xy plane: every wall for every ray
                sectors = [np.arange(model.ngeom)] * N_SECTORS
            self._ray_cache[part] = (model, data, sectors)
        return self._ray_cache[part]

    def table_angle(self, encoder_rad: np.ndarray) -> np.ndarray:
        """The table's true angle (n,) where the encoder reads ``encoder_rad`` (n,): short by its
        eccentricity."""
        t = self.truth
        e = t.encoder_eccentricity_urad * 1e-6
        return np.asarray(encoder_rad, float) - e * np.sin(
            np.asarray(encoder_rad, float) + t.encoder_eccentricity_phase_rad
        )

    def reading_mm(
        self, part: str, encoder_rad: np.ndarray, jitter_rad: np.ndarray | float = 0.0
    ) -> np.ndarray:
        """Noise-free readings (n,) at encoder angles (n,): MuJoCo's ray at the table's true
        angle, the table's runout, the probe's scale."""
        t = self.truth
        theta = self.table_angle(encoder_rad) + jitter_rad
        rho = self.exact_rho(part, theta)
        for k, a, ph in zip(t.runout_harmonics, t.runout_mm, t.runout_phase_rad):
            rho = rho + a * np.sin(round(k) * theta + ph)
        return rho * (1 + t.probe_scale_ppm * 1e-6) if t.probe_scale_ppm else rho

    def scan(self, part: str, rng: np.random.Generator) -> tuple[Scan, np.ndarray]:
        """One turn: the recording and, kept apart, the true table angles (n,)."""
        n = self.geometry.samples_per_turn
        nominal = np.arange(n) * 2 * np.pi / n
        jitter = rng.normal(0, np.deg2rad(self.truth.angle_jitter_deg), n)
        return self.record(self.reading_mm(part, nominal, jitter), rng), self.table_angle(
            nominal
        ) + jitter

    def record(self, exact_rho_mm: np.ndarray, rng: np.random.Generator) -> Scan:
        """The probe's noise and the encoder's quantisation on exact readings."""
        t = self.truth
        n = len(exact_rho_mm)
        noisy = exact_rho_mm + rng.normal(0, t.probe_noise_um / 1000, n)
        q = t.quantum_um / 1000
        return Scan(theta_rad=np.arange(n) * 2 * np.pi / n, rho_mm=np.round(noisy / q) * q)

    def radius_mm(self, part: str, phi_rad: np.ndarray) -> np.ndarray:
        """The part's true radius (n,) mm about the table's axis at holder polar angles
        ``phi_rad`` (n,): MuJoCo's ray from the axis, at the stylus's height, to the walls the
        stylus meets (the chords, not the exact curve: what a traced radius is judged by)."""
        self.turn_to(0.0)
        j = self.model.joint("theta").id
        origin = self.data.xanchor[j].copy()
        origin[2] = self.data.site_xpos[self._q][2]
        group = np.zeros(6, np.uint8)
        group[PLATE_GROUP if part == "plate" else LENS_GROUP] = 1
        out = np.empty(len(np.atleast_1d(phi_rad)))
        for k, phi in enumerate(np.atleast_1d(np.asarray(phi_rad, float))):
            u = np.array([np.cos(phi), np.sin(phi), 0.0])
            out[k] = mujoco.mj_ray(self.model, self.data, origin, u, group, 1, -1, self._geomid)
        if np.any(out < 0):
            raise RuntimeError(f"no wall of the {part} all round the table's axis")
        return out * 1000

    def true_outline_mm(self, part: str) -> np.ndarray:
        """The part's exact outline in the holder frame, dense, (n, 2) mm."""
        g = self.geometry
        if part == "plate":
            return densify(g.plate.outline(n_per_corner=4000), 0.001) + np.asarray(
                self.truth.plate_centre_mm
            )
        return _lens_outline_tree(g.lens).data.copy()

    def distance_to_outline_mm(self, part: str, points_mm: np.ndarray) -> np.ndarray:
        """Each point's distance to the part's exact outline (holder frame), (n,) mm, for points
        (n, 2): the nearest of its dense points (the lens's k-d tree is built once per shape)."""
        if part == "plate":
            from scipy.spatial import cKDTree

            return cKDTree(self.true_outline_mm("plate")).query(points_mm)[0]
        return _lens_outline_tree(self.geometry.lens).query(points_mm)[0]


def densify(outline_mm: np.ndarray, step_mm: float) -> np.ndarray:
    """A closed polyline resampled every ``step_mm`` of arc length, (m, 2)."""
    closed = np.vstack([outline_mm, outline_mm[:1]])
    s = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(closed, axis=0), axis=1))]
    t = np.arange(0.0, s[-1], step_mm)
    return np.c_[np.interp(t, s, closed[:, 0]), np.interp(t, s, closed[:, 1])]


def box_corners_xy(pos: np.ndarray, mat: np.ndarray, size: np.ndarray) -> np.ndarray:
    """The xy of each box's eight corners, (n, 8, 2): boxes at ``pos`` (n, 3), turned by ``mat``
    (n, 3, 3), half-sizes ``size`` (n, 3)."""
    signs = np.array(
        [[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], float
    )  # (8, 3)
    return (pos[:, None, :] + (signs[None] * size[:, None, :]) @ mat.transpose(0, 2, 1))[..., :2]


def ray_sectors(
    corners_xy: np.ndarray, q0_xy: np.ndarray, u0_xy: np.ndarray, n_sectors: int = N_SECTORS
) -> list[np.ndarray]:
    """Which boxes a ray can hit, by the sector of its direction, [(mask (n,)) per sector].

    The rays are one ray turned about the axis (the origin of ``corners_xy``, the boxes'
    corners (n, 8, 2)): at the table's angle theta it starts at R(theta) Q0 and runs along
    R(theta) u0 (``q0_xy``, unit ``u0_xy``), in the xy plane. In the table's frame the ray stays
    put and a box turns by -theta. Beyond |Q0| from the axis the ray passes each radius rho once,
    at a polar angle phi0 + delta(rho) (phi0 the direction's, delta monotone in rho: a straight
    line's polar angle always turns the same way). A point p of a box is thus met only by the
    ray of direction phi = angle(p) - delta(|p|): a box of polar extent [a_lo, a_hi] and radii
    [rho_lo, rho_hi] only by directions in [a_lo - max delta, a_hi - min delta]. A box reaching
    within |Q0| of the axis is kept for every direction. ``mj_ray`` over a sector's boxes then
    finds what it finds over all of them.
    """
    n = len(corners_xy)
    if n == 0:
        return [np.zeros(0, bool)] * n_sectors
    # polar extent of each box (the corners' convex hull, which does not surround the axis)
    mid = np.arctan2(corners_xy[..., 1].mean(axis=1), corners_xy[..., 0].mean(axis=1))
    rel = (np.arctan2(corners_xy[..., 1], corners_xy[..., 0]) - mid[:, None] + np.pi) % (
        2 * np.pi
    ) - np.pi
    a_lo, a_hi = mid + rel.min(axis=1), mid + rel.max(axis=1)
    # radial extent: the nearest point over every segment between two corners, the farthest corner
    i, j = np.triu_indices(8, 1)
    x0, y0 = corners_xy[:, i, 0], corners_xy[:, i, 1]
    dx, dy = corners_xy[:, j, 0] - x0, corners_xy[:, j, 1] - y0
    t = np.clip(-(x0 * dx + y0 * dy) / np.maximum(dx * dx + dy * dy, 1e-300), 0.0, 1.0)
    rho_lo = np.sqrt(np.min((x0 + t * dx) ** 2 + (y0 + t * dy) ** 2, axis=1))
    rho_hi = np.sqrt(np.max(np.sum(corners_xy**2, axis=2), axis=1))
    q0, u0 = np.asarray(q0_xy, float), np.asarray(u0_xy, float)
    near = rho_lo <= np.linalg.norm(q0) * (1 + 1e-9)
    phi0 = np.arctan2(u0[1], u0[0])

    def delta(rho):
        """The ray's polar angle at radius rho less its direction's, (n,)."""
        b = q0 @ u0
        s = -b + np.sqrt(np.maximum(b * b + rho * rho - q0 @ q0, 0.0))
        p = q0[None, :] + s[:, None] * u0[None, :]
        return (np.arctan2(p[:, 1], p[:, 0]) - phi0 + np.pi) % (2 * np.pi) - np.pi

    d_lo, d_hi = delta(np.where(near, rho_hi, rho_lo)), delta(rho_hi)
    lo, hi = a_lo - np.maximum(d_lo, d_hi), a_hi - np.minimum(d_lo, d_hi)
    centre, half = (lo + hi) / 2, (hi - lo) / 2 + 1e-9
    width = 2 * np.pi / n_sectors
    sector_mid = -np.pi + (np.arange(n_sectors) + 0.5) * width  # the sectors of arctan2's range
    gap = np.abs((centre[None, :] - sector_mid[:, None] + np.pi) % (2 * np.pi) - np.pi)
    return list(near[None, :] | (gap <= half[None, :] + width / 2))


@functools.lru_cache(maxsize=4)
def _walls_model(geometry: ProbeScannerGeometry, part: str) -> mujoco.MjModel:
    """A part's walls alone, compiled once per geometry (each twin copies it and places it)."""
    return mujoco.MjModel.from_xml_string(walls_mjcf(geometry, part))


@functools.lru_cache(maxsize=4)
def _lens_outline_tree(lens):
    """The rim's exact outline, 200,000 points, as a k-d tree (it depends on the shape alone)."""
    from scipy.spatial import cKDTree

    return cKDTree(lens.outline(n=200000))
