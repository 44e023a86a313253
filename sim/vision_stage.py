"""The as-built vision measuring machine: 21 ISO 230-1 component errors realised in MuJoCo.

Each axis has six component errors as smooth functions of its own scale reading u (mm):
positioning E_XX, two straightnesses, and roll, pitch, yaw (ISO 230-1 names for X: EXX, EYX,
EZX, EAX, EBX, ECX; for Y: EYY, EXY, EZY, EAY, EBY, ECY), plus the squareness EC0Y of Y to X
(the Y slide's direction) = 13 smooth functions and a constant; with the microscope's offsets
from the guides they make the 21 errors of the seed's Eq. 1-2. They are written into the error
joints of ``scenes.vision_stage``, so the table's true pose, and the plate point under the
microscope, come from MuJoCo's kinematics. The drives add a reversal value (lost motion between
scale and table) and random repeatability; the plate's circles carry manufacturing errors.

Units: readings and lengths in mm, angles in rad, inside MuJoCo m.
"""

from __future__ import annotations

import dataclasses
import functools

import mujoco
import numpy as np

from calibench.scenes.camera import MJ_TO_CV, world_to_cv_camera
from calibench.scenes.vision_stage import VisionStageGeometry, build_mjcf
from calibench.sim.renderer import LensRenderer
from calibench.sim.stage_drive import DriveErrors, travel_directions


@dataclasses.dataclass(frozen=True)
class Smooth:
    """f(u) = linear u + bow 4 (u/L)(1 - u/L) + amp sin(2 pi u / period + phase); L the travel."""

    linear: float = 0.0
    bow: float = 0.0
    amp: float = 0.0
    period: float = 100.0
    phase: float = 0.0

    def __call__(self, u, travel: float):
        u = np.asarray(u, float)
        s = u / travel
        return (
            self.linear * u
            + self.bow * 4 * s * (1 - s)
            + self.amp * np.sin(2 * np.pi * u / self.period + self.phase)
        )

    def coefficients(self) -> np.ndarray:
        """(linear, bow, amp, period, phase), (5,)."""
        return np.array([self.linear, self.bow, self.amp, self.period, self.phase])


@dataclasses.dataclass(frozen=True)
class AxisErrors:
    """The six component errors of one axis, in the axis's own frame: ``pos`` along it (mm),
    ``straight_1``, ``straight_2`` across it (mm; for X: along Y then Z; for Y: along X then Z),
    ``roll``, ``pitch``, ``yaw`` (rad, about X_m, Y_m, Z_m of the machine)."""

    pos: Smooth = Smooth()
    straight_1: Smooth = Smooth()
    straight_2: Smooth = Smooth()
    roll: Smooth = Smooth()
    pitch: Smooth = Smooth()
    yaw: Smooth = Smooth()

    @functools.cached_property
    def _table(self) -> np.ndarray:
        """The six components' (linear, bow, amp, period, phase), (5, 6)."""
        return np.stack(
            [getattr(self, f.name).coefficients() for f in dataclasses.fields(self)], axis=1
        )


def axes_errors(
    x: AxisErrors, y: AxisErrors, u_mm: np.ndarray, travel_mm: np.ndarray
) -> np.ndarray:
    """Both axes' six errors at their positions ``u_mm`` (2,) over their ``travel_mm`` (2,),
    (2, 6): rows X then Y, columns in AxisErrors' field order; one evaluation for the twelve,
    bit-equal to each Smooth's own."""
    return _axes_errors(np.concatenate([x._table, y._table], axis=1), u_mm, travel_mm)


_AXIS_OF = np.repeat([0, 1], 6)  # the axis of each of the twelve errors


def _axes_errors(
    table: np.ndarray, u_mm: np.ndarray, travel_mm: np.ndarray | tuple[float, float]
) -> np.ndarray:
    """:func:`axes_errors` from both axes' tables side by side, (5, 12); ``u_mm`` (..., 2) gives
    (..., 2, 6)."""
    linear, bow, amp, period, phase = table
    u_mm = np.asarray(u_mm, float)
    u, travel = u_mm[..., _AXIS_OF], np.asarray(travel_mm, float)[_AXIS_OF]
    s = u / travel
    e = linear * u + bow * 4 * s * (1 - s) + amp * np.sin(2 * np.pi * u / period + phase)
    return e.reshape(*u_mm.shape[:-1], 2, 6)


# Sized after the seed paper: about 60 um uncompensated positioning error, of which the scales'
# linear error is most; a periodic scale error no cubic can follow; bows and angular errors of
# a few um and tens of urad, acting through the guides' offsets.
DEFAULT_X = AxisErrors(
    pos=Smooth(linear=210e-6, bow=2.0e-3, amp=0.7e-3, period=95.0, phase=0.4),
    straight_1=Smooth(bow=3.0e-3, amp=0.4e-3, period=140.0),
    straight_2=Smooth(bow=-2.0e-3),
    roll=Smooth(bow=8e-6),
    pitch=Smooth(bow=12e-6, amp=3e-6, period=150.0),
    yaw=Smooth(linear=4e-8, bow=-14e-6, amp=2e-6, period=120.0, phase=1.0),
)
DEFAULT_Y = AxisErrors(
    pos=Smooth(linear=-140e-6, bow=-1.5e-3, amp=0.5e-3, period=70.0, phase=2.0),
    straight_1=Smooth(bow=2.5e-3),
    straight_2=Smooth(bow=1.5e-3),
    roll=Smooth(bow=-6e-6),
    pitch=Smooth(bow=9e-6),
    yaw=Smooth(linear=6e-8, bow=8e-6),
)


@dataclasses.dataclass(frozen=True)
class VisionStageTruth:
    x: AxisErrors = DEFAULT_X
    y: AxisErrors = DEFAULT_Y
    squareness_rad: float = 25e-6  # EC0Y: the Y slide leans towards +X by this angle
    reversal_um: tuple[float, float] = (0.6, 0.5)  # lost motion on reversal, X and Y
    repeatability_um: float = 0.12  # 1-sigma random positioning, each axis
    plate_phi_rad: float = 1.5e-3  # the plate as first laid down, about +Z
    plate_error_um: float = 0.5  # 1-sigma manufacturing error of each circle, each direction
    drive_x: DriveErrors = DriveErrors()  # beyond the error map: what discover --twin writes
    drive_y: DriveErrors = DriveErrors()


@dataclasses.dataclass(frozen=True)
class LineRuler:
    """A glass line ruler laid on the table: graduations every ``pitch_mm`` from ``origin_mm``
    (table frame) along direction ``angle_rad`` (from the table's x), manufacturing error
    ``graduation_errors_mm`` (n,)."""

    origin_mm: np.ndarray
    angle_rad: float
    pitch_mm: float
    graduation_errors_mm: np.ndarray

    def graduation_mm(self, k: int) -> np.ndarray:
        """The position of graduation ``k`` along the ruler, (2,) mm, in the table's frame."""
        u = np.array([np.cos(self.angle_rad), np.sin(self.angle_rad)])
        return self.origin_mm + u * (k * self.pitch_mm + self.graduation_errors_mm[k])

    @property
    def direction(self) -> np.ndarray:
        """The ruler's unit direction, (2,)."""
        return np.array([np.cos(self.angle_rad), np.sin(self.angle_rad)])


class VisionStageSim:
    """Move by scale readings, read the true plate point under the microscope, render."""

    def __init__(
        self,
        geometry: VisionStageGeometry,
        truth: VisionStageTruth,
        rng: np.random.Generator,
        render: bool = True,
    ):
        self.geometry = geometry
        self.truth = truth
        self.rng = rng
        n = geometry.plate.n
        self.plate_errors_mm = rng.normal(0, truth.plate_error_um / 1000, (n * n, 2))
        # every circle's true centre in the plate's frame, (n * n, 3) m
        self._circles_m = np.c_[
            (geometry.plate.centres_mm() + self.plate_errors_mm) / 1000, np.zeros(n * n)
        ]
        xml, assets = build_mjcf(geometry, self.plate_errors_mm)
        self.model = mujoco.MjModel.from_xml_string(xml, assets)
        self.data = mujoco.MjData(self.model)
        m = self.model
        self._q = {
            name: m.jnt_qposadr[m.joint(name).id]
            for name in ["x", "y"] + [f"{p}{c}" for p in ("ex", "ey") for c in "xyzabc"]
        }
        self._move_q = [
            self._q[n]
            for n in (
                "x",
                "exx",
                "exy",
                "exz",
                "exa",
                "exb",
                "exc",
                "y",
                "eyx",
                "eyy",
                "eyz",
                "eya",
                "eyb",
                "eyc",
            )
        ]
        s = truth.squareness_rad
        m.jnt_axis[m.joint("y").id] = [-np.sin(s), -np.cos(s), 0.0]  # Y_m leaning towards X_m
        self._plate = m.body("plate").id
        self._table = m.body("table").id
        self._cam = m.camera("microscope").id
        self.set_plate_yaw(truth.plate_phi_rad)
        self._dir = np.array([1.0, 1.0])
        self._reading = np.zeros(2)
        self._tables: tuple[AxisErrors | None, AxisErrors | None, np.ndarray | None]
        self._tables = (None, None, None)
        self._body = {name: m.body(name).id for name in ("table", "plate")}
        self.renderer = LensRenderer(m, "microscope", geometry.camera) if render else None
        self.move(0.0, 0.0)

    # --- the machine -------------------------------------------------------------------------
    def move(self, x_mm: float, y_mm: float, temp_c: float | None = None) -> None:
        """Servo both axes to the scale readings (x_mm, y_mm), the room at ``temp_c`` (None: the
        drives' reference temperature)."""
        self.move_path(np.array([[x_mm, y_mm]], float), temp_c=temp_c)

    def _joint_positions(
        self, target: np.ndarray, direction: np.ndarray, noise_mm: np.ndarray, temp_c: float | None
    ) -> np.ndarray:
        """The slides' and error joints' positions (m, 14) (``_move_q``'s order) after moves to
        the scale readings ``target`` (m, 2) made in ``direction`` (m, 2), with the drives'
        random scatter ``noise_mm`` (m, 2)."""
        t, g = self.truth, self.geometry
        lost = 0.5 * np.array(t.reversal_um) / 1000 * direction
        if not (t.drive_x.perfect and t.drive_y.perfect):
            T = None if temp_c is None else np.full(len(target), float(temp_c))
            lost = lost + np.stack(
                [
                    np.zeros(len(target))
                    if d.perfect
                    else d.error_mm(target[:, k], direction[:, k], T)
                    for k, d in enumerate((t.drive_x, t.drive_y))
                ],
                axis=1,
            )
        tx, ty, table = self._tables
        if table is None or tx is not t.x or ty is not t.y:  # the truth's axes: tabled once
            table = np.concatenate([t.x._table, t.y._table], axis=1)
            self._tables = (t.x, t.y, table)
        e = _axes_errors(table, target, g.travel_mm)  # (m, axis, pos s1 s2 roll pitch yaw)
        along = e[:, :, 0] + (lost + noise_mm)
        # straight_1 of X is along Y_m, of Y along X_m; the joints a, b turn about X_m, Y_m: the X
        # carriage's roll and pitch, the Y carriage's pitch and roll
        q = np.empty((len(target), 14))
        q[:, 0], q[:, 1], q[:, 2:4], q[:, 4:7] = (
            target[:, 0] / 1000,
            along[:, 0] / 1000,
            e[:, 0, 1:3] / 1000,
            e[:, 0, 3:],
        )
        q[:, 7], q[:, 8], q[:, 9], q[:, 10] = (
            target[:, 1] / 1000,
            e[:, 1, 1] / 1000,
            along[:, 1] / 1000,
            e[:, 1, 2] / 1000,
        )
        q[:, 11:] = e[:, 1, [4, 3, 5]]
        return q

    def move_path(
        self,
        targets: np.ndarray,
        read: np.ndarray | None = None,
        axis: int = 0,
        noise_um: float = 0.05,
        temp_c: float | None = None,
    ) -> np.ndarray:
        """:meth:`move` through the scale readings ``targets`` (m, 2) in order, and read the
        interferometer (:meth:`interferometer_mm`) along ``axis`` after each move where ``read``
        (m,) is true: the readings, (read.sum(),) mm. The same as those moves and readings one
        by one, random draws included: the moves' errors in one evaluation, the draws in one
        batch in the order the single calls make them."""
        targets = np.asarray(targets, float)
        read = np.zeros(len(targets), bool) if read is None else np.asarray(read, bool)
        direction = travel_directions(self._reading, targets, self._dir)
        draws = 2 + read.astype(int)  # a move's scatter (x, y), then a reading's noise
        first = np.cumsum(draws) - draws
        z = self.rng.standard_normal(int(draws.sum()))
        noise = z[first[:, None] + [0, 1]] * (self.truth.repeatability_um / 1000)
        qpos = self._joint_positions(targets, direction, noise, temp_c)
        at = []
        for i in range(len(targets)):
            self.data.qpos[self._move_q] = qpos[i]
            mujoco.mj_kinematics(self.model, self.data)
            mujoco.mj_camlight(self.model, self.data)
            if read[i]:
                at.append(self.point_in_body_mm("table")[axis])
        self._dir, self._reading = direction[-1].copy(), targets[-1].copy()
        return np.array(at) + z[first[read] + 2] * (noise_um / 1000)

    @property
    def reading_mm(self) -> np.ndarray:
        """The linear scales' readings (x, y) mm."""
        return self._reading.copy()

    def set_plate_yaw(self, phi_rad: float) -> None:
        """Lay the plate at angle phi about +Z, turning about circle (0, 0)."""
        self.model.body_quat[self._plate] = [np.cos(phi_rad / 2), 0, 0, np.sin(phi_rad / 2)]
        self.plate_phi_rad = float(phi_rad)
        mujoco.mj_kinematics(self.model, self.data)

    # --- truth ----------------------------------------------------------------------------------
    def true_point_mm(self, x_mm: float, y_mm: float, body: str = "table") -> np.ndarray:
        """The point under the microscope at readings (x, y), approached from +, without the
        drives' random scatter: the geometric truth. The machine's state is left as it was."""
        saved = (self._reading.copy(), self._dir.copy(), self.data.qpos.copy(), self.truth)
        self.truth = dataclasses.replace(self.truth, repeatability_um=0.0)
        try:
            self._reading = np.array([x_mm, y_mm]) - 1.0  # approach from below
            self.move(x_mm, y_mm)
            return self.point_in_body_mm(body)
        finally:
            self._reading, self._dir, self.data.qpos[:], self.truth = saved
            mujoco.mj_kinematics(self.model, self.data)

    def _under_microscope_world(self) -> np.ndarray:
        """Where the optical axis meets the plate's top face, world (3,) m."""
        R = self.data.xmat[self._plate].reshape(3, 3)
        o = self.data.xpos[self._plate]
        cam = self.data.cam_xpos[self._cam]
        d = -self.data.cam_xmat[self._cam].reshape(3, 3)[:, 2]  # viewing direction
        n = R[:, 2]
        return cam + d * ((o - cam) @ n) / (d @ n)

    def point_in_body_mm(self, body: str) -> np.ndarray:
        """The point under the microscope in a body's frame (``table`` or ``plate``), (2,) mm."""
        b = self._body[body] if body in self._body else self.model.body(body).id
        p = self._under_microscope_world()
        R = self.data.xmat[b].reshape(3, 3)
        return (R.T @ (p - self.data.xpos[b]))[:2] * 1000

    def true_circle_px(self, k: int) -> np.ndarray:
        """Exact image of circle k's centre (manufacturing error included), (2,) px."""
        c = self._circles_m[k]
        R = self.data.xmat[self._plate].reshape(3, 3)
        world = self.data.xpos[self._plate] + R @ c
        cam = world_to_cv_camera(
            world[None], self.data.cam_xpos[self._cam], self.data.cam_xmat[self._cam].reshape(3, 3)
        )
        return self.geometry.camera.project(cam, distort=False)[0]

    def plate2cam(self) -> tuple[np.ndarray, np.ndarray]:
        """The plate frame in the OpenCV camera frame: R (3, 3), t (3,) mm."""
        Rc = self.data.cam_xmat[self._cam].reshape(3, 3) @ MJ_TO_CV
        Rp = self.data.xmat[self._plate].reshape(3, 3)
        return Rc.T @ Rp, Rc.T @ (
            self.data.xpos[self._plate] - self.data.cam_xpos[self._cam]
        ) * 1000

    # --- instruments ------------------------------------------------------------------------------
    def render(
        self,
        noise_dn: float = 0.0,
        psf_px: float = 0.0,
        window: tuple[int, int, int, int] | None = None,
    ) -> np.ndarray:
        """The microscope's image, (h, w, 3) uint8, with sensor noise and blur; ``window``
        (u0, v0, u1, v1) px reads out that area of interest only (:meth:`LensRenderer.render`)."""
        if self.renderer is None:
            raise RuntimeError("this simulator was built without a renderer")
        return self.renderer.render(self.data, self.rng, noise_dn, psf_px, window)

    def interferometer_mm(self, axis: int, noise_um: float = 0.05) -> float:
        """A laser interferometer's reading along machine axis ``axis`` (0 = X, 1 = Y): the
        table's displacement at the microscope's axis, mm (zeroing is the user's)."""
        return float(self.point_in_body_mm("table")[axis] + self.rng.normal(0, noise_um / 1000))

    def ruler_reading(
        self, ruler: LineRuler, k: int, axis: int, other_reading_mm: float, aim_um: float = 0.3
    ) -> float:
        """Scale reading of ``axis`` at which graduation k of the ruler crosses the optical axis,
        the other axis held at ``other_reading_mm``; the operator's aim scatters by ``aim_um``.

        Found as the operator would: move, look, move again (secant steps on the true position).
        """
        g = ruler.graduation_mm(k)
        u = ruler.direction

        def miss(r):
            s = [r, other_reading_mm] if axis == 0 else [other_reading_mm, r]
            self.move(*s)
            return float((self.point_in_body_mm("table") - g) @ u)

        r0 = float(g[axis] - (self.point_in_body_mm("table")[axis] - self._reading[axis]))
        r1 = r0 + 0.01
        f0, f1 = miss(r0), miss(r1)
        for _ in range(8):
            if abs(f1) < 1e-5 or f1 == f0:  # 10 nm: far below the drive's repeatability
                break
            r0, r1, f0 = r1, r1 - f1 * (r1 - r0) / (f1 - f0), f1
            f1 = miss(r1)
        return r1 + self.rng.normal(0, aim_um / 1000)

    def close(self) -> None:
        """Free the renderer's GL context."""
        if self.renderer is not None:
            self.renderer.close()
