"""The as-built belt stage: injected error maps and board misalignment, realised in MuJoCo.

Commands are stepper pulses (25,000 pulses = 100 mm). The true carriage position is the
commanded one plus the axis error map of the seed paper's form (Eq. 1),
``e(x, y) = c0 + c1 x + c2 y + c3 x^2 + c4 x y + c5 y^2`` (x, y commanded, mm), written
into the slide joints; everything the camera sees then comes from MuJoCo's kinematics.
The machine is homed at pulse (0, 0), which makes the true error there zero: c0 = 0.
"""

from __future__ import annotations

import dataclasses

import mujoco
import numpy as np
from scipy.spatial.transform import Rotation

from calibench.errors import BadInput
from calibench.scenes.belt_stage import (
    CALIB_BOARD_GROUP,
    CALIB_BOARD_PARK,
    STAGE_BOARD_GROUP,
    BeltStageGeometry,
    board_to_body,
    build_mjcf,
)
from calibench.scenes.camera import MJ_TO_CV, world_to_cv_camera
from calibench.sim.renderer import Exposure, LensRenderer
from calibench.sim.stage_drive import BeltDrive, DriveErrors, ElasticBelt, travel_direction

PULSES_PER_MM = 250.0  # 25,000 pulses = 100 mm
# around the board's border in an area-of-interest read-out: wider than the blur's reach (3 psf)
# and than any error of predicting the board's place from the command (a few px)
WINDOW_MARGIN_PX = 16

# Magnitude of the paper's Table 3 fits (Eq. 20-21, with the typesetting slips corrected),
# units mm, mm/mm, mm/mm^2; c0 = 0 by homing.
PAPER_ERROR_X = (0.0, 5.888e-3, 1.699e-3, 4.817e-6, -1.264e-6, 3.190e-8)
PAPER_ERROR_Y = (0.0, 1.572e-3, 7.542e-3, -4.046e-7, 1.129e-6, 3.310e-6)


def quadratic_terms(x_mm: np.ndarray, y_mm: np.ndarray) -> np.ndarray:
    """Monomials (1, x, y, x^2, xy, y^2) of the error map, shape (n, 6)."""
    x, y = np.asarray(x_mm, float), np.asarray(y_mm, float)
    return np.stack([np.ones_like(x), x, y, x * x, x * y, y * y], axis=-1)


@dataclasses.dataclass(frozen=True)
class BeltStageTruth:
    """What was injected; never shown to an estimator.

    error_x, error_y : (6,) coefficients c0..c5 of each axis's error map (mm).
    board_yaw_rad : rotation of the board about world +z relative to the stage axes.
    drive_x, drive_y : each drive's errors beyond the map (lost motion, run-out, thermal).
    belt_x, belt_y : each axis's belt and carriage friction; ``ea_n`` > 0 makes the belt elastic
        (MuJoCo's tendons): the carriage then lags its command by friction over stiffness.
    """

    error_x: tuple[float, ...] = PAPER_ERROR_X
    error_y: tuple[float, ...] = PAPER_ERROR_Y
    board_yaw_rad: float = 4e-3
    drive_x: DriveErrors = DriveErrors()
    drive_y: DriveErrors = DriveErrors()
    belt_x: BeltDrive = BeltDrive()
    belt_y: BeltDrive = BeltDrive()

    def __post_init__(self):
        if len(self.error_x) != 6 or len(self.error_y) != 6:
            raise BadInput("error maps take six coefficients c0..c5")
        if self.error_x[0] != 0 or self.error_y[0] != 0:
            raise BadInput("c0 must be 0: the stage is homed at pulse (0, 0)")

    def error_mm(self, x_cmd_mm: np.ndarray, y_cmd_mm: np.ndarray) -> np.ndarray:
        """True positioning error (ex, ey) at commanded positions, shape (n, 2) mm."""
        m = quadratic_terms(x_cmd_mm, y_cmd_mm)
        return np.stack([m @ np.asarray(self.error_x), m @ np.asarray(self.error_y)], axis=-1)


class BeltStageSim:
    """The stage in MuJoCo: move by pulses, read true board poses, render the camera."""

    def __init__(
        self,
        geometry: BeltStageGeometry,
        truth: BeltStageTruth,
        render: bool = True,
        supersample: int = 2,
    ):
        self.geometry = geometry
        self.truth = truth
        pad = geometry.camera.padding_px()
        xml, assets = build_mjcf(geometry, render_pad_px=pad, supersample=supersample)
        self.model = mujoco.MjModel.from_xml_string(xml, assets)
        self.data = mujoco.MjData(self.model)
        self._board = self.model.body("board").id
        self._calib = self.model.body("calib_board").id
        self._cam = self.model.camera("overhead").id
        half = truth.board_yaw_rad / 2
        self.model.body_quat[self._board] = [np.cos(half), 0, 0, np.sin(half)]
        self._b2body_R, self._b2body_t = board_to_body(geometry)
        self.renderer = (
            LensRenderer(self.model, "overhead", geometry.camera, supersample) if render else None
        )
        self._belts = [
            ElasticBelt(travel, belt) if belt.ea_n > 0 else None
            for travel, belt in zip(geometry.travel_mm, (truth.belt_x, truth.belt_y))
        ]
        self._dir = np.array([1.0, 1.0])  # homed from below
        self._cmd = np.zeros(2)
        for belt in self._belts:
            if belt is not None:
                belt.move(-1.0)
        self.move(0, 0)

    # --- motion ---------------------------------------------------------------------------
    def move(self, x_pulses: int, y_pulses: int, temp_c: float | None = None) -> np.ndarray:
        """Command the stage, the room at ``temp_c`` (None: the drives' reference temperature);
        returns the true carriage position (x, y) in mm."""
        cmd = np.array([x_pulses, y_pulses], float) / PULSES_PER_MM
        self._dir = travel_direction(self._cmd, cmd, self._dir)
        self._cmd = cmd
        true_mm = cmd + self.truth.error_mm(cmd[:1], cmd[1:])[0]
        T = None if temp_c is None else np.array([temp_c])
        for k, (drive, belt) in enumerate(
            zip((self.truth.drive_x, self.truth.drive_y), self._belts)
        ):
            if not drive.perfect:
                true_mm[k] += drive.error_mm(cmd[k : k + 1], self._dir[k : k + 1], T)[0]
            if belt is not None:
                true_mm[k] += belt.move(cmd[k]) - cmd[k]
        self.data.qpos[:2] = true_mm / 1000
        mujoco.mj_kinematics(self.model, self.data)
        mujoco.mj_camlight(self.model, self.data)
        return true_mm

    def carriage_mm(self) -> np.ndarray:
        """The carriage's true position (x, y) mm."""
        return self.data.xpos[self.model.body("y_carriage").id][:2] * 1000

    # --- truth in camera terms --------------------------------------------------------------
    def cam2world(self) -> tuple[np.ndarray, np.ndarray]:
        """OpenCV camera frame to world: rotation (3, 3), position (3,) m."""
        R = self.data.cam_xmat[self._cam].reshape(3, 3) @ MJ_TO_CV
        return R, self.data.cam_xpos[self._cam].copy()

    def board2world(self, body: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Board frame (OpenCV convention, m) to world, from MuJoCo's body pose."""
        b = self._board if body is None else body
        R_body = self.data.xmat[b].reshape(3, 3)
        return R_body @ self._b2body_R, self.data.xpos[b] + R_body @ self._b2body_t

    def board2cam(self, body: int | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Board frame to the OpenCV camera frame: rotation (3, 3), translation (3,) in mm."""
        Rb, pb = self.board2world(body)
        Rc, pc = self.cam2world()
        return Rc.T @ Rb, Rc.T @ (pb - pc) * 1000

    def true_corners_px(self, calib: bool = False) -> np.ndarray:
        """Exact (distorted) projection of the board's inner corners, shape (n, 2) px."""
        return self.corners_px([self.view_frame(calib)])[0]

    def view_frame(
        self, calib: bool = False
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """What a view's exact corners depend on, now: the board's (stage's, or with ``calib``
        the free one's) rotation (3, 3) and position (3,) m in the world, and MuJoCo's camera
        orientation (3, 3) and position (3,) m."""
        Rb, pb = self.board2world(self._calib if calib else None)
        return (
            Rb,
            pb,
            self.data.cam_xmat[self._cam].reshape(3, 3).copy(),
            self.data.cam_xpos[self._cam].copy(),
        )

    def corners_px(self, frames: list) -> np.ndarray:
        """Exact (distorted) projections of the board's inner corners in several views, each
        given by its :meth:`view_frame`, (n_views, n, 2) px: all views in one projection."""
        Rb, pb, cam_xmat, cam_pos = (np.array(f) for f in zip(*frames))
        world = pb[:, None] + (self.geometry.board.corners_mm() / 1000) @ Rb.transpose(0, 2, 1)
        cam = world_to_cv_camera(world, cam_pos[:, None], cam_xmat)
        return self.geometry.camera.project(cam.reshape(-1, 3)).reshape(
            cam.shape[0], cam.shape[1], 2
        )

    # --- the calibration board, held in front of the camera -----------------------------------
    def place_calib_board(self, R_board2cam: np.ndarray, t_board2cam_mm: np.ndarray) -> None:
        """Put the free board at a pose given in the camera frame (t in mm)."""
        Rc, pc = self.cam2world()
        R_b2w = Rc @ R_board2cam
        p_b2w = pc + Rc @ (np.asarray(t_board2cam_mm) / 1000)
        R_body = R_b2w @ self._b2body_R.T
        p_body = p_b2w - R_body @ self._b2body_t
        mocap = self.model.body_mocapid[self._calib]
        self.data.mocap_pos[mocap] = p_body
        q = np.empty(4)
        mujoco.mju_mat2Quat(q, R_body.ravel())
        self.data.mocap_quat[mocap] = q
        mujoco.mj_kinematics(self.model, self.data)

    def park_calib_board(self) -> None:
        """Move the calibration board out of the camera's view."""
        mocap = self.model.body_mocapid[self._calib]
        self.data.mocap_pos[mocap] = CALIB_BOARD_PARK
        self.data.mocap_quat[mocap] = [1, 0, 0, 0]
        mujoco.mj_kinematics(self.model, self.data)

    # --- the camera --------------------------------------------------------------------------
    def render(
        self,
        calib: bool = False,
        rng: np.random.Generator | None = None,
        noise_dn: float = 0.0,
        psf_px: float = 0.0,
        window: tuple[int, int, int, int] | None = None,
    ) -> np.ndarray:
        """What the camera sees, through its lens: (height, width, 3) uint8.

        ``calib`` shows the free calibration board and hides the stage's, so each image holds
        exactly one board. ``psf_px`` (1-sigma, px) is the optics' blur and ``noise_dn`` (grey
        levels, 1-sigma, drawn from ``rng``) the sensor's noise. ``window`` (u0, v0, u1, v1) px
        reads out that area of interest only (:meth:`LensRenderer.render`).
        """
        return self._lens().develop(self.capture(calib, rng, noise_dn, psf_px, window))

    def capture(
        self,
        calib: bool = False,
        rng: np.random.Generator | None = None,
        noise_dn: float = 0.0,
        psf_px: float = 0.0,
        window: tuple[int, int, int, int] | None = None,
    ) -> Exposure:
        """:meth:`render`'s GL work (on this thread) and noise draws (in the frames' order,
        before it returns): the frame that ``renderer.develop`` makes the image of, on any
        thread. The arguments: :meth:`render`'s.
        """
        lens = self._lens()
        lens.show_groups({STAGE_BOARD_GROUP: not calib, CALIB_BOARD_GROUP: calib})
        return lens.capture(self.data, rng, noise_dn, psf_px, window)

    def _lens(self) -> LensRenderer:
        if self.renderer is None:
            raise RuntimeError("this simulator was built without a renderer")
        return self.renderer

    def board_window(self, calib: bool = False) -> tuple[int, int, int, int]:
        """The area of interest (u0, v0, u1, v1) px, half-open, that holds the board now with its
        white border and :data:`WINDOW_MARGIN_PX` around it: where a camera reading out an area
        of interest would put it, the board's position being predicted by the stage's command to
        far better than the margin."""
        c = self.true_corners_px(calib)
        b = self.geometry.board
        grid = c.reshape(b.rows, b.cols, 2)
        square = max(
            np.abs(np.diff(grid, axis=1)).sum(axis=-1).max(),
            np.abs(np.diff(grid, axis=0)).sum(axis=-1).max(),
        )
        lo = np.floor(c.min(axis=0) - 2 * square - WINDOW_MARGIN_PX).astype(int)
        hi = np.ceil(c.max(axis=0) + 2 * square + WINDOW_MARGIN_PX).astype(int)
        cam = self.geometry.camera
        lo, hi = np.maximum(lo, 0), np.minimum(hi, [cam.width, cam.height])
        return int(lo[0]), int(lo[1]), int(hi[0]), int(hi[1])

    def close(self) -> None:
        """Free the renderer's GL context."""
        if self.renderer is not None:
            self.renderer.close()


BLOCK = 16  # attempts at placing a calibration view, judged together


def _view_attempts(draw, fu, fv, cam, corners, centre, half, outer, edge_px):
    """Each attempt's pose (R (k, 3, 3), t (k, 3) mm) from its draws (k, 6), and whether it
    fits: the printed face towards the camera, every corner ``edge_px`` inside, the plate in."""
    R = Rotation.from_rotvec(draw[:, :3]).as_matrix()
    z = draw[:, 3]
    hw, hh = half[0] * cam.fx / z, half[1] * cam.fy / z  # plate half size, px
    fu_j, fv_j = np.clip(fu + draw[:, 4], 0, 1), np.clip(fv + draw[:, 5], 0, 1)
    u = hw + fu_j * (cam.width - 2 * hw)
    v = hh + fv_j * (cam.height - 2 * hh)
    c_cam = np.stack([(u - cam.cx) / cam.fx * z, (v - cam.cy) / cam.fy * z, z], axis=1)
    t = c_cam - R @ centre
    k = len(draw)
    uv = cam.project((corners @ R.transpose(0, 2, 1) + t[:, None]).reshape(-1, 3)).reshape(k, -1, 2)
    uv_plate = cam.project(
        ((outer + centre) @ R.transpose(0, 2, 1) + t[:, None]).reshape(-1, 3)
    ).reshape(k, -1, 2)
    inside = ((uv > edge_px) & (uv < [cam.width - edge_px, cam.height - edge_px])).all(axis=(1, 2))
    plate_in = ((uv_plate > 0) & (uv_plate < [cam.width, cam.height])).all(axis=(1, 2))
    # the printed face must face the camera (board z, into the plate, points away)
    return (R[:, 2, 2] > 0.3) & inside & plate_in, R, t


INTRINSIC_VIEW_DEPTH_MM = (750.0, 1150.0)  # the calibration views' board distances from the camera


def intrinsic_view_poses(
    geometry: BeltStageGeometry,
    n_views: int,
    rng: np.random.Generator,
    depth_mm: tuple[float, float] = INTRINSIC_VIEW_DEPTH_MM,
    max_tilt_rad: float = 0.6,
    edge_px: float = 12.0,
):
    """Board poses in the camera frame for intrinsic calibration, spread over the image.

    Board centres are aimed at a jittered grid of image points (corners included, where the
    lens bends most) with tilts up to ``max_tilt_rad``; a pose is redrawn until every corner
    lands at least ``edge_px`` inside the image. Returns a list of (R (3, 3), t (3,) mm).
    """
    cam = geometry.camera
    board = geometry.board
    corners = board.corners_mm()
    centre = np.r_[board.centre_mm, 0.0]
    half = np.array(board.size_mm) / 2
    nx = int(np.ceil(np.sqrt(n_views * 4 / 3)))
    ny = int(np.ceil(n_views / nx))
    # grid fractions 0..1 of the feasible range of the board centre: 0 and 1 touch the edges
    targets = [(i / max(nx - 1, 1), j / max(ny - 1, 1)) for j in range(ny) for i in range(nx)][
        :n_views
    ]
    outer = np.array([[sx * half[0], sy * half[1], 0] for sx in (-1, 1) for sy in (-1, 1)])
    # one attempt's six draws: two tilts, the spin, the depth, the aim's jitter in u and v
    lo = np.array([-max_tilt_rad, -max_tilt_rad, -0.4, depth_mm[0], -0.1, -0.1])
    hi = np.array([max_tilt_rad, max_tilt_rad, 0.4, depth_mm[1], 0.1, 0.1])
    poses = []
    for fu, fv in targets:
        found = None
        for _ in range(2000 // BLOCK):
            # a block of attempts judged at once; the generator is then moved past exactly the
            # attempts a one-at-a-time search would have drawn, up to the first that fits
            state = rng.bit_generator.state
            draw = rng.uniform(lo, hi, (BLOCK, 6))
            ok, R, t = _view_attempts(draw, fu, fv, cam, corners, centre, half, outer, edge_px)
            if ok.any():
                j = int(np.argmax(ok))
                rng.bit_generator.state = state
                rng.uniform(lo, hi, (j + 1, 6))
                found = (R[j], t[j])
                break
        if found is None:
            raise RuntimeError("could not place a calibration view inside the image")
        poses.append(found)
    return poses
