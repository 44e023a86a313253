"""Scene ``vision-stage``: the X-Y table of a vision measuring machine under a fixed microscope.

World frame: z up, metres. The microscope looks straight down along the world z axis at x = y =
0 (its image x along world +x, image v along world -y). The table moves under it; increasing a
scale reading moves the table towards -x (or -y), so the camera looks further along +x (+y) of
the plate. The machine's table-motion axes are therefore X_m = -x, Y_m = -y, Z_m = +z.

Chain: world > X carriage (slide ``x``) > six error joints at the X guide's reference point
(``ex ey ez`` slides along X_m Y_m Z_m, ``ea eb ec`` hinges about them) > Y carriage (slide
``y``) > six error joints at the Y guide's reference point > table > plate. The error joints are
set by ``sim.vision_stage`` from the ISO 230-1 component errors; because they sit at the guides,
the angular errors act through the real offsets to the microscope's axis (Abbe errors).

The plate carries 21 x 21 dark circles, 5 mm across at 15 mm pitch, drawn as texture on one
tile geom per circle (so a per-circle manufacturing error is a tile offset).
"""

from __future__ import annotations

import dataclasses
import functools

import cv2
import numpy as np

from calibench.scenes.camera import PinholeCamera

TILE_MM = 15.0
TILE_HALF_THICKNESS_M = 0.0005


@dataclasses.dataclass(frozen=True)
class CirclePlate:
    """The standard plate: ``n x n`` circles of ``diameter_mm`` at ``pitch_mm``."""

    n: int = 21
    pitch_mm: float = 15.0
    diameter_mm: float = 5.0

    def centres_mm(self) -> np.ndarray:
        """Nominal circle centres in the plate frame, shape (n * n, 2), index = j * n + i."""
        j, i = np.mgrid[0 : self.n, 0 : self.n]
        return np.stack([i.ravel(), j.ravel()], axis=1) * self.pitch_mm

    def tile_texture(
        self, px: int = 1024, dark: int = 25, bright: int = 235, supersample: int = 4
    ) -> np.ndarray:
        """One tile's texture: a centred disc, area-sampled, (px, px, 3) uint8."""
        s = supersample
        c = (np.arange(px * s) + 0.5) / (px * s) * self.pitch_mm - self.pitch_mm / 2  # mm
        r2 = c[None, :] ** 2 + c[:, None] ** 2
        inside = (r2 <= (self.diameter_mm / 2) ** 2).reshape(px, s, px, s).mean(axis=(1, 3))
        img = np.rint(bright - (bright - dark) * inside).astype(np.uint8)
        return np.repeat(img[:, :, None], 3, axis=2)


def microscope() -> PinholeCamera:
    """768 x 576 px over 7.99 x 5.99 mm at a 150 mm working distance (10.4 um/px), no distortion."""
    f_px = 150.0 / 0.0104
    return PinholeCamera(
        width=768,
        height=576,
        fx=f_px,
        fy=f_px,
        cx=383.5,
        cy=287.5,
        k1=0.0,
        k2=0.0,
        p1=0.0,
        p2=0.0,
        k3=0.0,
    )


@dataclasses.dataclass(frozen=True)
class VisionStageGeometry:
    """Nominal geometry, mm unless stated."""

    travel_mm: tuple[float, float] = (300.0, 200.0)
    plate: CirclePlate = CirclePlate()
    camera: PinholeCamera = dataclasses.field(default_factory=microscope)
    working_distance_mm: float = 150.0
    plate_surface_mm: float = 100.0  # height of the plate's top face
    # Scale readings at which circle (0, 0) is under the microscope, plate square and exact.
    plate_origin_reading_mm: tuple[float, float] = (7.0, 9.0)
    # Reference points of the guides (where the angular errors act), at reading 0, in the
    # world: the X guide runs beside the table and below it, the Y guide under the table.
    x_guide_ref_mm: tuple[float, float, float] = (-150.0, -130.0, 40.0)
    y_guide_ref_mm: tuple[float, float, float] = (-120.0, -100.0, 70.0)


def build_mjcf(
    g: VisionStageGeometry, tile_offsets_mm: np.ndarray | None = None
) -> tuple[str, dict[str, bytes]]:
    """MJCF text and assets. ``tile_offsets_mm`` (n*n, 2) moves each circle off its nominal
    place (the plate's manufacturing error); the sim passes it, nominal is zero."""
    cam = g.camera
    attrs = " ".join(f'{k}="{v}"' for k, v in cam.mjcf_attributes().items())
    pad = cam.padding_px()  # the renderer's border, kept for a lens with distortion
    z_plate = g.plate_surface_mm / 1000
    z_cam = z_plate + g.working_distance_mm / 1000
    xg = np.array(g.x_guide_ref_mm) / 1000
    yg = np.array(g.y_guide_ref_mm) / 1000
    ox, oy = (v / 1000 for v in g.plate_origin_reading_mm)
    n = g.plate.n
    offsets = (
        np.zeros((n * n, 2)) if tile_offsets_mm is None else np.asarray(tile_offsets_mm, float)
    )
    centres = (g.plate.centres_mm() + offsets) / 1000
    half = TILE_MM / 2000
    tiles = "\n".join(
        f'            <geom name="tile{k}" type="box" size="{half} {half} {TILE_HALF_THICKNESS_M}" '
        f'pos="{cx:.9f} {cy:.9f} {-TILE_HALF_THICKNESS_M}" material="circle" contype="0" '
        'conaffinity="0" mass="0.001"/>'
        for k, (cx, cy) in enumerate(centres)
    )

    # Body positions are chosen so that, with every error zero, the table frame's origin sits
    # under the microscope at readings (0, 0) and the plate frame's origin (circle 0, 0) at the
    # plate origin reading.
    def error_joints(p: str) -> str:
        return "\n".join(
            [
                f'<joint name="{p}x" type="slide" axis="-1 0 0" range="-0.01 0.01" class="error"/>',
                f'<joint name="{p}y" type="slide" axis="0 -1 0" range="-0.01 0.01" class="error"/>',
                f'<joint name="{p}z" type="slide" axis="0 0 1" range="-0.01 0.01" class="error"/>',
                f'<joint name="{p}a" type="hinge" axis="-1 0 0" range="-0.01 0.01" class="error"/>',
                f'<joint name="{p}b" type="hinge" axis="0 -1 0" range="-0.01 0.01" class="error"/>',
                f'<joint name="{p}c" type="hinge" axis="0 0 1" range="-0.01 0.01" class="error"/>',
            ]
        )

    xml = f"""
<mujoco model="vision-stage">
  <compiler angle="radian"/>
  <option gravity="0 0 -9.81" timestep="0.002"/>
  <visual>
    <global offwidth="{cam.width + 2 * pad}" offheight="{cam.height + 2 * pad}"/>
    <headlight ambient="0.6 0.6 0.6" diffuse="0.2 0.2 0.2" specular="0 0 0"/>
    <map znear="0.001" zfar="50"/>
  </visual>
  <default>
    <joint damping="5" armature="0.01"/>
    <!-- error joints are set kinematically; stiff springs hold them if the world is stepped -->
    <default class="error"><joint stiffness="1e5" damping="100"/></default>
  </default>
  <asset>
    <texture name="circle" type="2d" file="circle.png"/>
    <material name="circle" texture="circle" emission="1" specular="0" shininess="0"/>
    <material name="base" rgba="0.3 0.32 0.35 1"/>
    <material name="carriage" rgba="0.55 0.57 0.6 1"/>
    <material name="optics" rgba="0.1 0.1 0.12 1"/>
  </asset>
  <worldbody>
    <light name="top" pos="0 0 1" dir="0 0 -1" directional="true" diffuse="0.3 0.3 0.3"
        castshadow="false"/>
    <geom name="base" type="box" size="0.35 0.3 0.02" pos="-0.15 -0.1 0.0" material="base"/>
    <camera name="microscope" pos="0 0 {z_cam}" xyaxes="1 0 0 0 1 0" {attrs}/>
    <geom name="objective" type="cylinder" size="0.02 0.04" pos="0 0 {z_cam + 0.045}"
        material="optics" contype="0" conaffinity="0"/>
    <body name="x_carriage" pos="0 0 0">
      <joint name="x" type="slide" axis="-1 0 0" range="-0.01 {g.travel_mm[0] / 1000 + 0.01}"/>
      <geom name="x_saddle" type="box" size="0.2 0.04 0.012" pos="{xg[0]} {xg[1]} {xg[2] - 0.015}"
          material="carriage" mass="5"/>
      <body name="x_err" pos="{xg[0]} {xg[1]} {xg[2]}">
        {error_joints("ex")}
        <inertial pos="0 0 0" mass="0.01" diaginertia="1e-6 1e-6 1e-6"/>
        <body name="y_carriage" pos="{-xg[0]} {-xg[1]} {-xg[2]}">
          <joint name="y" type="slide" axis="0 -1 0" range="-0.01 {g.travel_mm[1] / 1000 + 0.01}"/>
          <geom name="y_saddle" type="box" size="0.05 0.2 0.012"
              pos="{yg[0]} {yg[1]} {yg[2] - 0.015}" material="carriage" mass="4"/>
          <body name="y_err" pos="{yg[0]} {yg[1]} {yg[2]}">
            {error_joints("ey")}
            <inertial pos="0 0 0" mass="0.01" diaginertia="1e-6 1e-6 1e-6"/>
            <body name="table" pos="{-yg[0]} {-yg[1]} {-yg[2]}">
              <geom name="table_top" type="box" size="0.19 0.19 0.01"
                  pos="{0.15 - 0.005} {0.1 - 0.005} {z_plate - 0.016}" material="carriage"
                  mass="8"/>
              <body name="plate" pos="{ox} {oy} {z_plate}">
{tiles}
              </body>
            </body>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""
    return xml, {"circle.png": _tile_png(g.plate)}


@functools.lru_cache(maxsize=8)
def _tile_png(plate: CirclePlate) -> bytes:
    """The tile's texture as PNG bytes, made once per plate (a Monte-Carlo worker builds the
    scene every trial; the texture depends on the plate alone)."""
    ok, png = cv2.imencode(".png", plate.tile_texture())
    return png.tobytes()


def default_scenes() -> dict:
    """This module's scene with its default geometry, for the scene tests: {"": () -> (MJCF,
    assets)}."""
    return {"": lambda: build_mjcf(VisionStageGeometry())}
