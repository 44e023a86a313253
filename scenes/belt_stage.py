"""Scene ``belt-stage``: a 1 m x 1 m belt-driven two-axis stage under a fixed camera.

World frame: z up, origin at the stage's home corner; MuJoCo units (m, rad). The X carriage
slides along world x, the Y carriage rides on it along world y (nested slides), and the
chessboard plate lies face up on the Y carriage with its centre on the carriage origin. The
camera hangs above the middle of the travel, looking straight down, its image x along world x
(so image v grows towards -y). A second, free (mocap) copy of the board serves the intrinsic
calibration views; each board lives in its own geom group so a render can show one only.

Only nominal geometry lives here: the injected errors are applied by ``sim.belt_stage``.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from calibench.scenes.camera import PinholeCamera
from calibench.scenes.checkerboard import Chessboard

STAGE_BOARD_GROUP = 2
CALIB_BOARD_GROUP = 3
CALIB_BOARD_PARK = (0.5, 0.5, -5.0)  # below the floor, out of every view


@dataclasses.dataclass(frozen=True)
class BeltStageGeometry:
    """Nominal geometry. Lengths in mm (the machine's unit), converted to m in the MJCF."""

    travel_mm: tuple[float, float] = (1000.0, 1000.0)
    board: Chessboard = Chessboard(cols=9, rows=6, square_mm=50.0, margin_mm=25.0)
    camera: PinholeCamera = PinholeCamera()
    board_top_mm: float = 60.0  # height of the board face above the floor
    camera_height_mm: float = 1840.0  # camera centre above the floor: the plate stays in view

    @property
    def camera_pos_mm(self) -> np.ndarray:
        """The overhead camera's position in the world frame, (3,) mm."""
        return np.array([self.travel_mm[0] / 2, self.travel_mm[1] / 2, self.camera_height_mm])


def build_mjcf(
    geometry: BeltStageGeometry, render_pad_px: int = 0, supersample: int = 1
) -> tuple[str, dict[str, bytes]]:
    """MJCF text and its assets (the board texture PNG).

    ``render_pad_px`` widens the render buffer so a padded ideal image can be rendered for the
    lens model, ``supersample`` times larger for anti-aliasing; the camera's intrinsics stay
    those of ``geometry.camera``.
    """
    g = geometry
    cam = g.camera
    tx, ty = (t / 1000 for t in g.travel_mm)
    bw, bh = (s / 1000 for s in g.board.size_mm)
    z_board = g.board_top_mm / 1000
    cam_pos = g.camera_pos_mm / 1000
    attrs = " ".join(f'{k}="{v}"' for k, v in cam.mjcf_attributes().items())
    off_w = (cam.width + 2 * render_pad_px) * supersample
    off_h = (cam.height + 2 * render_pad_px) * supersample
    plate_t = PLATE_HALF_THICKNESS_M
    xml = f"""
<mujoco model="belt-stage">
  <compiler angle="radian"/>
  <option gravity="0 0 -9.81" timestep="0.002"/>
  <visual>
    <global offwidth="{off_w}" offheight="{off_h}"/>
    <headlight ambient="0.5 0.5 0.5" diffuse="0.3 0.3 0.3" specular="0 0 0"/>
  </visual>
  <asset>
    <texture name="board" type="2d" file="board.png"/>
    <!-- emission 1: the plate shows its texture's exact grey levels, whatever the lights -->
    <material name="board" texture="board" emission="1" specular="0" shininess="0" rgba="1 1 1 1"/>
    <material name="frame" rgba="0.35 0.37 0.4 1"/>
    <material name="carriage" rgba="0.55 0.3 0.15 1"/>
    <material name="floor" rgba="0.18 0.2 0.22 1"/>
    <material name="camera" rgba="0.1 0.1 0.12 1"/>
  </asset>
  <worldbody>
    <!-- no shadows: the mast and boom would shade the plate in the measurement images -->
    <light name="top" pos="{tx / 2} {ty / 2} 3" dir="0 0 -1" directional="true"
        diffuse="0.4 0.4 0.4" castshadow="false"/>
    <geom name="floor" type="plane" size="{tx + 1} {ty + 1} 0.05" pos="{tx / 2} {ty / 2} 0"
        material="floor"/>
    <geom name="rail_x_front" type="box" size="{tx / 2 + 0.3} 0.02 0.01" pos="{tx / 2} -0.35 0.01"
        material="frame"/>
    <geom name="rail_x_back" type="box" size="{tx / 2 + 0.3} 0.02 0.01"
        pos="{tx / 2} {ty + 0.35} 0.01" material="frame"/>
    <camera name="overhead" pos="{cam_pos[0]} {cam_pos[1]} {cam_pos[2]}" xyaxes="1 0 0 0 1 0"
        {attrs}/>
    <!-- camera housing, boom and mast: above the lens and outside the field of view -->
    <geom name="camera_housing" type="box" size="0.035 0.03 0.03"
        pos="{cam_pos[0]} {cam_pos[1]} {cam_pos[2] + 0.035}" material="camera" contype="0"
        conaffinity="0"/>
    <geom name="boom" type="box" size="{(cam_pos[0] + 0.75) / 2} 0.02 0.02"
        pos="{(cam_pos[0] - 0.75) / 2} {cam_pos[1]} {cam_pos[2] + 0.085}" material="frame"
        contype="0" conaffinity="0"/>
    <geom name="mast" type="box" size="0.03 0.03 {(cam_pos[2] + 0.105) / 2}"
        pos="-0.75 {cam_pos[1]} {(cam_pos[2] + 0.105) / 2}" material="frame" contype="0"
        conaffinity="0"/>
    <body name="x_carriage" pos="0 0 0">
      <joint name="x" type="slide" axis="1 0 0" range="-0.05 {tx + 0.05}" damping="50"/>
      <geom name="gantry" type="box" size="0.04 {ty / 2 + 0.37} 0.012" pos="0 {ty / 2} 0.022"
          material="frame" mass="8"/>
      <body name="y_carriage" pos="0 0 0">
        <joint name="y" type="slide" axis="0 1 0" range="-0.05 {ty + 0.05}" damping="50"/>
        <geom name="carriage" type="box" size="0.08 0.08 0.008"
            pos="0 0 {z_board - plate_t * 2 - 0.008}" material="carriage" mass="2"/>
        <body name="board" pos="0 0 {z_board - plate_t}">
          <geom name="board" type="box" size="{bw / 2} {bh / 2} {plate_t}" material="board"
              group="{STAGE_BOARD_GROUP}" mass="0.5" contype="0" conaffinity="0"/>
        </body>
      </body>
    </body>
    <body name="calib_board" mocap="true"
        pos="{CALIB_BOARD_PARK[0]} {CALIB_BOARD_PARK[1]} {CALIB_BOARD_PARK[2]}">
      <geom name="calib_board" type="box" size="{bw / 2} {bh / 2} {plate_t}" material="board"
          group="{CALIB_BOARD_GROUP}" contype="0" conaffinity="0"/>
    </body>
  </worldbody>
</mujoco>
"""
    return xml, {"board.png": g.board.texture_png()}


PLATE_HALF_THICKNESS_M = 0.004
# The board body's frame has z up out of the printed (top) face; the board frame (OpenCV's)
# has z into the plate. MuJoCo draws a texture image's row 0 along the face's +y edge and
# the texture stores board y growing down its rows: so board y runs along body -y.
BOARD_TO_BODY_R = np.diag([1.0, -1.0, -1.0])


def board_to_body(geometry: BeltStageGeometry) -> tuple[np.ndarray, np.ndarray]:
    """Rotation (3, 3) and translation (3,) in m taking board-frame points to the board body."""
    c = geometry.board.centre_mm / 1000
    return BOARD_TO_BODY_R, np.array([-c[0], c[1], PLATE_HALF_THICKNESS_M])


def default_scenes() -> dict:
    """This module's scene with its default geometry, for the scene tests: {"": () -> (MJCF,
    assets)}."""
    return {"": lambda: build_mjcf(BeltStageGeometry())}
