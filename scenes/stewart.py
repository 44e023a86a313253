"""Scene ``stewart``: a 6-6 Stewart platform (parallel machine tool) and a laser tracker's plate.

World = base frame, z up, metres. Leg i: a body at the base hinge B_i with a universal joint (two
hinges, about x then y) whose z axis is the leg's axis, and a rod that slides along it; the rod's
end (site ``leg{i}_end``) is tied to the platform's hinge (site ``plat{i}``) by an equality
``connect`` (the spherical joint). The platform is a free body carrying three reflectors. The
tracker stands in turn in three locating holes of a measuring plate on the floor; three
reference nests with known coordinates let it find where it stands. Contacts are off.

MuJoCo's constraints are soft: ``sim.stewart`` sets every joint from closed-form inverse
kinematics and checks the loop closure, it does not step the mechanism to its poses.
"""

from __future__ import annotations

import dataclasses

import numpy as np


def _ring(radius, angles_deg, z=0.0):
    a = np.deg2rad(angles_deg)
    return np.c_[radius * np.cos(a), radius * np.sin(a), np.full(len(a), z)]


@dataclasses.dataclass(frozen=True)
class StewartGeometry:
    """Nominal geometry, mm."""

    base_hinges_mm: np.ndarray = dataclasses.field(
        default_factory=lambda: _ring(500.0, [-15, 15, 105, 135, 225, 255])
    )
    platform_hinges_mm: np.ndarray = dataclasses.field(
        default_factory=lambda: _ring(300.0, [-45, 45, 75, 165, 195, 285])
    )
    initial_lengths_mm: np.ndarray = dataclasses.field(default_factory=lambda: np.full(6, 650.0))
    home_height_mm: float = 750.0
    reflectors_mm: np.ndarray = (
        dataclasses.field(  # on the platform, platform frame (a CMM gave them)
            default_factory=lambda: _ring(200.0, [30, 150, 270], z=40.0)
        )
    )
    # known points on the base and on two columns: spread in height, so that trilateration
    # pins the stations' heights too
    reference_nests_mm: np.ndarray = dataclasses.field(
        default_factory=lambda: np.array(
            [[700.0, -500.0, 0.0], [800.0, 500.0, 700.0], [-700.0, 700.0, 1300.0]]
        )
    )
    # the measuring plate's holes M1-M3, on an upright plate beside the machine
    station_holes_mm: np.ndarray = dataclasses.field(
        default_factory=lambda: np.array(
            [[1500.0, -500.0, 300.0], [1600.0, 500.0, 900.0], [1400.0, -100.0, 1500.0]]
        )
    )


LEG_STROKE_MM = (
    400.0,
    1200.0,
)  # the legs' slides' range: the pin-to-pin lengths the platform can take
PLATFORM_KG = 20.0


def build_mjcf(
    g: StewartGeometry,
    B_mm: np.ndarray,
    r_mm: np.ndarray,
    reflectors_mm: np.ndarray,
    stations_mm: np.ndarray,
) -> str:
    """The platform's MJCF: base, platform and six legs (a slide between two universal joints)."""
    B, r = np.asarray(B_mm) / 1000, np.asarray(r_mm) / 1000
    legs, sites, eqs = "", "", ""
    for i in range(6):
        legs += f"""
    <body name="leg{i}" pos="{B[i, 0]} {B[i, 1]} {B[i, 2]}">
      <joint name="leg{i}_ux" type="hinge" axis="1 0 0"/>
      <joint name="leg{i}_uy" type="hinge" axis="0 1 0"/>
      <geom name="leg{i}_cyl" type="cylinder" fromto="0 0 0 0 0 0.35" size="0.025"
          rgba="0.5 0.52 0.55 1" mass="2" contype="0" conaffinity="0"/>
      <body name="leg{i}_rod">
        <joint name="leg{i}_slide" type="slide" axis="0 0 1"
            range="{LEG_STROKE_MM[0] / 1000} {LEG_STROKE_MM[1] / 1000}"/>
        <geom name="leg{i}_rod" type="capsule" fromto="0 0 -0.45 0 0 0" size="0.014"
            rgba="0.8 0.8 0.82 1" mass="1" contype="0" conaffinity="0"/>
        <site name="leg{i}_end" pos="0 0 0" size="0.01"/>
      </body>
    </body>"""
        sites += (
            f'\n      <site name="plat{i}" pos="{r[i, 0]} {r[i, 1]} {r[i, 2]}" size="0.012" '
            'rgba="0.9 0.3 0.2 1"/>'
        )
        eqs += f'\n    <connect site1="leg{i}_end" site2="plat{i}"/>'
    refl = "".join(
        f'\n      <site name="reflector{k}" pos="{p[0] / 1000} {p[1] / 1000} {p[2] / 1000}" '
        'size="0.01" rgba="0.9 0.9 0.2 1"/>'
        for k, p in enumerate(reflectors_mm)
    )
    nests = "".join(
        f'\n    <site name="nest{k}" pos="{p[0] / 1000} {p[1] / 1000} {p[2] / 1000}" size="0.012" '
        'rgba="0.2 0.6 0.9 1"/>'
        for k, p in enumerate(g.reference_nests_mm)
    )
    stations = "".join(
        f'\n    <site name="station{k}" pos="{p[0] / 1000} {p[1] / 1000} {p[2] / 1000}" '
        'size="0.02" rgba="0.9 0.9 0.9 1"/>'
        for k, p in enumerate(stations_mm)
    )
    h = g.home_height_mm / 1000
    return f"""
<mujoco model="stewart">
  <compiler angle="radian"/>
  <option gravity="0 0 -9.81" timestep="0.001"/>
  <visual><global offwidth="640" offheight="480"/></visual>
  <worldbody>
    <light name="top" pos="0 0 4" dir="0 0 -1" directional="true" castshadow="false"/>
    <geom name="floor" type="plane" size="3 3 0.01" pos="0 0 -0.05" rgba="0.2 0.22 0.25 1"
        contype="0" conaffinity="0"/>
    <geom name="base_plate" type="cylinder" size="0.6 0.02" pos="0 0 -0.02" rgba="0.35 0.36 0.4 1"
        contype="0" conaffinity="0"/>
    <geom name="measuring_plate" type="box" size="0.02 0.6 0.7" pos="1.55 0 0.9"
        rgba="0.4 0.4 0.45 0.6" contype="0" conaffinity="0"/>{nests}{stations}{legs}
    <body name="platform" pos="0 0 {h}">
      <freejoint name="platform"/>
      <geom name="platform" type="cylinder" size="0.34 0.015" rgba="0.6 0.45 0.25 1"
          mass="{PLATFORM_KG}" contype="0" conaffinity="0"/>{sites}{refl}
    </body>
  </worldbody>
  <equality>{eqs}
  </equality>
</mujoco>
"""


def default_scenes() -> dict:
    """This module's scene with its default geometry, for the scene tests: {"": () -> (MJCF,
    assets)}."""

    def scene():
        g = StewartGeometry()
        return build_mjcf(
            g, g.base_hinges_mm, g.platform_hinges_mm, g.reflectors_mm, g.station_holes_mm
        ), {}

    return {"": scene}
