"""Scene ``probe-scanner``: a rotary frame tracer, its calibration plate and a spectacle rim.

World frame: z up, metres; the turntable turns about the world z axis through the origin. The
frame holder (fixed) holds two openings, each a closed wall of thin box geoms whose inner faces
trace the opening: the calibration plate's 45 mm square with rounded corners, and a spectacle
rim (a superellipse). Each part sits in its own geom group, so the probe's ray (``mj_ray``)
sees one part at a time. The rail rides the turntable; the stylus starts at the site ``Q``.

Curved walls are chords of the exact curve, fine enough that the ray's error stays below 0.05 um
(sagitta of the longest chord).
"""

from __future__ import annotations

import copy
import dataclasses
import functools

import numpy as np

PLATE_GROUP = 1
LENS_GROUP = 3
WALL_HALF_THICKNESS_M = 0.001
WALL_HALF_HEIGHT_M = 0.004
RAY_HEIGHT_M = 0.004


@dataclasses.dataclass(frozen=True)
class RoundedSquare:
    """The calibration plate's opening: half-side and corner radius, mm."""

    half_side_mm: float = 22.5
    corner_radius_mm: float = 5.0

    def outline(self, n_per_corner: int = 400) -> np.ndarray:
        """Closed outline, counter-clockwise, (n, 2) mm (corner arcs sampled, sides straight)."""
        a, r = self.half_side_mm, self.corner_radius_mm
        b = a - r
        pts = []
        for k, (sx, sy) in enumerate([(1, 1), (-1, 1), (-1, -1), (1, -1)]):
            t = np.linspace(0, np.pi / 2, n_per_corner) + k * np.pi / 2
            pts.append(np.c_[sx * b + r * np.cos(t), sy * b + r * np.sin(t)])
        return np.vstack(pts)


@dataclasses.dataclass(frozen=True)
class Superellipse:
    """A spectacle rim's opening: |x'/A|^p + |y'/B|^p = 1 in a frame turned by ``angle_rad``
    and centred at ``centre_mm`` in the holder; mm."""

    A_mm: float = 25.0
    B_mm: float = 18.0
    p: float = 2.6
    angle_rad: float = 0.05
    centre_mm: tuple[float, float] = (0.8, -0.4)

    def outline(self, n: int = 20000) -> np.ndarray:
        """``n`` points of the outline at equal parameter steps around it, (n, 2) mm."""
        t = np.linspace(0, 2 * np.pi, n, endpoint=False)
        c, s = np.cos(t), np.sin(t)
        x = self.A_mm * np.sign(c) * np.abs(c) ** (2 / self.p)
        y = self.B_mm * np.sign(s) * np.abs(s) ** (2 / self.p)
        ca, sa = np.cos(self.angle_rad), np.sin(self.angle_rad)
        return np.c_[ca * x - sa * y, sa * x + ca * y] + np.asarray(self.centre_mm)


@dataclasses.dataclass(frozen=True)
class ProbeScannerNominal:
    """The mechanism's design values, used before calibration (and to pick alpha0's branch)."""

    d_mm: float = 7.5
    dL_mm: float = 3.4
    alpha0_rad: float = 0.30


@dataclasses.dataclass(frozen=True)
class ProbeScannerGeometry:
    plate: RoundedSquare = RoundedSquare()
    lens: Superellipse = Superellipse()
    samples_per_turn: int = 1600
    rail_length_mm: float = 60.0


def wall_geoms(outline_mm: np.ndarray, group: int, prefix: str, material: str) -> str:
    """Box geoms whose inner faces are the chords of a closed counter-clockwise outline."""
    p = outline_mm / 1000
    q = np.roll(p, -1, axis=0)
    mid, seg = (p + q) / 2, q - p
    length = np.linalg.norm(seg, axis=1)
    keep = length > 1e-9
    out = []
    for k, (m, s, L) in enumerate(zip(mid[keep], seg[keep], length[keep])):
        t = s / L
        normal = np.array([t[1], -t[0]])  # outward for a counter-clockwise outline
        c = m + normal * WALL_HALF_THICKNESS_M
        yaw = np.arctan2(t[1], t[0])
        out.append(
            f'<geom name="{prefix}{k}" type="box" size="{L / 2 + 1e-5:.9f} {WALL_HALF_THICKNESS_M} '
            f'{WALL_HALF_HEIGHT_M}" pos="{c[0]:.9f} {c[1]:.9f} {WALL_HALF_HEIGHT_M}" '
            f'euler="0 0 {yaw:.12f}" group="{group}" material="{material}" contype="0" '
            'conaffinity="0"/>'
        )
    return "\n        ".join(out)


@functools.lru_cache(maxsize=8)
def _walls_xml(g: ProbeScannerGeometry) -> tuple[str, str]:
    """The plate's and the lens's wall geoms (the same in every as-built twin of a geometry:
    a Monte-Carlo study builds them once per worker)."""
    return (
        wall_geoms(g.plate.outline(n_per_corner=200), PLATE_GROUP, "plate_wall", "plate"),
        wall_geoms(g.lens.outline(n=1440), LENS_GROUP, "lens_wall", "lens"),
    )


def walls_mjcf(g: ProbeScannerGeometry, part: str) -> str:
    """MJCF of one part's walls alone (``part``: "plate" or "lens"), in the holder's bodies as
    :func:`build_mjcf` has them, the part's body at the origin (the twin puts it where the part
    is clamped): what the probe's rays are cast against, without the other part's geoms."""
    plate_walls, lens_walls = _walls_xml(g)
    walls, rgba = (
        (plate_walls, "0.7 0.72 0.75 1") if part == "plate" else (lens_walls, "0.55 0.25 0.2 1")
    )
    return f"""
<mujoco model="probe-scanner-{part}-walls">
  <compiler angle="radian"/>
  <asset><material name="{part}" rgba="{rgba}"/></asset>
  <worldbody>
    <body name="holder" pos="0 0 0">
      <body name="{part}" pos="0 0 0">
        {walls}
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def build_mjcf(
    g: ProbeScannerGeometry,
    d_mm: float,
    dL_mm: float,
    alpha0_rad: float,
    plate_centre_mm=(0.0, 0.0),
) -> str:
    """MJCF of the tracer with the rail at (d, dL, alpha0) and the plate centred as given."""
    plate_walls, lens_walls = _walls_xml(g)
    q, tip, rail_mid = rail_placement_m(g, d_mm, dL_mm, alpha0_rad)
    pc = np.asarray(plate_centre_mm) / 1000
    return f"""
<mujoco model="probe-scanner">
  <compiler angle="radian"/>
  <option gravity="0 0 -9.81" timestep="0.002"/>
  <visual><global offwidth="640" offheight="480"/></visual>
  <asset>
    <material name="plate" rgba="0.7 0.72 0.75 1"/>
    <material name="lens" rgba="0.55 0.25 0.2 1"/>
    <material name="table" rgba="0.25 0.27 0.3 1"/>
    <material name="rail" rgba="0.8 0.6 0.2 1"/>
  </asset>
  <worldbody>
    <light name="top" pos="0 0 1" dir="0 0 -1" directional="true" castshadow="false"/>
    <body name="holder" pos="0 0 0">
      <body name="plate" pos="{pc[0]} {pc[1]} 0">
        {plate_walls}
      </body>
      <body name="lens" pos="0 0 0">
        {lens_walls}
      </body>
    </body>
    <body name="turntable" pos="0 0 -0.01">
      <joint name="theta" type="hinge" axis="0 0 1" damping="0.1"/>
      <geom name="disc" type="cylinder" size="0.045 0.004" material="table" mass="1.0" group="2"/>
      <body name="rail" pos="0 0 0.01">
        <geom name="rail" type="box" size="{g.rail_length_mm / 2000} 0.002 0.0015"
            pos="{rail_mid[0]} {rail_mid[1]} 0.012"
            euler="0 0 {alpha0_rad}" material="rail" mass="0.1" group="2" contype="0"
            conaffinity="0"/>
        <site name="Q" pos="{q[0]} {q[1]} {RAY_HEIGHT_M}" size="0.0008"/>
        <site name="rail_dir" pos="{tip[0]} {tip[1]} {RAY_HEIGHT_M}"
            size="0.0004"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def rail_placement_m(
    g: ProbeScannerGeometry, d_mm: float, dL_mm: float, alpha0_rad: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Where the rail at (d, dL, alpha0) puts, in the turntable's frame, the stylus's start Q,
    the site 1 cm along the rail from it and the rail's middle: each (2,) m, x and y."""
    u = np.array([np.cos(alpha0_rad), np.sin(alpha0_rad)])
    n = np.array([-np.sin(alpha0_rad), np.cos(alpha0_rad)])
    q = (d_mm * n + dL_mm * u) / 1000
    return q, q + u * 0.01, (d_mm * n + (dL_mm + g.rail_length_mm / 2) * u) / 1000


@functools.lru_cache(maxsize=4)
def _nominal_model(g: ProbeScannerGeometry):
    """The tracer of the design values, compiled once per geometry (its 2,000-odd wall geoms
    take tens of milliseconds to parse and compile: a Monte-Carlo trial's twin copies it)."""
    import mujoco

    n = ProbeScannerNominal()
    return mujoco.MjModel.from_xml_string(build_mjcf(g, n.d_mm, n.dL_mm, n.alpha0_rad))


def as_built_model(
    g: ProbeScannerGeometry,
    d_mm: float,
    dL_mm: float,
    alpha0_rad: float,
    plate_centre_mm=(0.0, 0.0),
):
    """The MjModel of :func:`build_mjcf` with the same arguments, without parsing its MJCF: a
    copy of the design's model with the as-built written in. Written: the plate's body, the
    stylus's two sites, the rail's geom and its body's centre of mass and inertial frame (the
    rail's one geom: its pose, as the compiler finds it); ``mj_setConst`` redoes what the
    compiler derives at qpos0. A test checks every array against the MJCF's model."""
    import mujoco

    model = copy.copy(_nominal_model(g))
    q, tip, mid = rail_placement_m(g, d_mm, dL_mm, alpha0_rad)
    model.body_pos[model.body("plate").id, :2] = np.asarray(plate_centre_mm) / 1000
    model.site_pos[model.site("Q").id, :2] = q
    model.site_pos[model.site("rail_dir").id, :2] = tip
    rail = model.geom("rail").id
    model.geom_pos[rail, :2] = mid
    mujoco.mju_euler2Quat(model.geom_quat[rail], np.array([0.0, 0.0, alpha0_rad]), "xyz")
    body = model.geom_bodyid[rail]
    model.body_ipos[body], model.body_iquat[body] = model.geom_pos[rail], model.geom_quat[rail]
    mujoco.mj_setConst(model, mujoco.MjData(model))
    return model


def default_scenes() -> dict:
    """This module's scene with its default geometry and nominal probe, for the scene tests:
    {"": () -> (MJCF, assets)}."""

    def scene():
        n = ProbeScannerNominal()
        return build_mjcf(ProbeScannerGeometry(), n.d_mm, n.dL_mm, n.alpha0_rad), {}

    return {"": scene}
