"""Scene ``arm-cmm``: a 6-joint articulated-arm CMM with a probe stylus, a laser tracker, a cone
and a length bar.

World frame = the arm's base frame, z up, metres. The arm is a chain of Denavit-Hartenberg frames
(the seed's convention T = Rot(Z, theta) Trans(0, 0, d) Trans(a, 0, 0) Rot(X, alpha)): body
``joint{i}`` is frame i-1 turned by the joint's zero offset, its hinge turns about its z axis,
and body ``link{i}`` sits at (a_i, 0, d_i) turned by alpha_i about x: frame i. The probe is the
origin of frame 7 (site ``probe``); the tracker's reflector is a site fixed in link 7.
Contacts are off: the arm is a kinematic instrument; masses and inertias are those of a passive
arm of about 1 m reach, so gravity is there for later experiments.
"""

from __future__ import annotations

import dataclasses

import numpy as np

# The seed's Table 1, nominal: a, d (mm) and alpha (rad) of links 1..7.
NOMINAL_A_MM = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
NOMINAL_D_MM = (100.0, 150.0, 450.0, 100.0, 350.0, 100.0, 150.0)
NOMINAL_ALPHA_RAD = (-np.pi / 2, np.pi / 2, np.pi / 2, -np.pi / 2, -np.pi / 2, np.pi / 2, 0.0)
LINK_MASS_KG = (1.5, 1.2, 1.4, 0.6, 0.9, 0.35, 0.08)
LINK_RADIUS_M = (0.035, 0.03, 0.025, 0.025, 0.02, 0.018, 0.004)


@dataclasses.dataclass(frozen=True)
class ArmGeometry:
    a_mm: tuple = NOMINAL_A_MM
    d_mm: tuple = NOMINAL_D_MM
    alpha_rad: tuple = NOMINAL_ALPHA_RAD
    joint_limits_rad: tuple = ((-np.pi, np.pi),) * 6
    reflector_offset_mm: tuple = (0.0, 0.0, 0.0)  # nominal: the reflector replaces the probe ball


def _quat_z(t):
    return f"{np.cos(t / 2):.15g} 0 0 {np.sin(t / 2):.15g}"


def _quat_x(t):
    return f"{np.cos(t / 2):.15g} {np.sin(t / 2):.15g} 0 0"


def build_mjcf(g: ArmGeometry, a_mm, d_mm, alpha_rad, theta0_rad, reflector_offset_mm,
               tracker_pos_m, tracker_quat, cones_m) -> str:
    """MJCF of an arm with the given (as-built) DH values, the tracker at its pose, the cones."""
    body = ""
    close = ""
    for i in range(7):
        a, d, al = a_mm[i] / 1000, d_mm[i] / 1000, alpha_rad[i]
        r = LINK_RADIUS_M[i]
        joint = (f'<joint name="q{i + 1}" type="hinge" axis="0 0 1" range="{g.joint_limits_rad[i][0]} '
                 f'{g.joint_limits_rad[i][1]}" damping="0.5" armature="0.01"/>') if i < 6 else ""
        length = np.hypot(a, d)
        geom = (f'<geom name="link{i + 1}" type="capsule" fromto="0 0 0 {a} 0 {d}" size="{r}" '
                f'mass="{LINK_MASS_KG[i]}" rgba="0.75 0.75 0.78 1" contype="0" conaffinity="0"/>'
                if length > 1e-9 else "")
        body += f"""
      <body name="joint{i + 1}" quat="{_quat_z(theta0_rad[i])}">
        {joint}
        {geom}
        <body name="link{i + 1}" pos="{a} 0 {d}" quat="{_quat_x(al)}">"""
        close = "\n        </body>\n      </body>" + close
    ro = np.asarray(reflector_offset_mm) / 1000
    body += f"""
          <site name="probe" pos="0 0 0" size="0.003" rgba="0.9 0.2 0.2 1"/>
          <site name="reflector" pos="{ro[0]} {ro[1]} {ro[2]}" size="0.006" rgba="0.9 0.9 0.2 1"/>"""
    tp = np.asarray(tracker_pos_m)
    ca, cb = (np.asarray(c) for c in cones_m)
    return f"""
<mujoco model="arm-cmm">
  <compiler angle="radian"/>
  <option gravity="0 0 -9.81" timestep="0.001"/>
  <visual><global offwidth="640" offheight="480"/></visual>
  <worldbody>
    <light name="top" pos="0 0 3" dir="0 0 -1" directional="true" castshadow="false"/>
    <geom name="floor" type="plane" size="2 2 0.01" pos="0 0 -0.35" rgba="0.2 0.22 0.25 1" contype="0" conaffinity="0"/>
    <geom name="pedestal" type="cylinder" size="0.06 0.17" pos="0 0 -0.18" rgba="0.3 0.3 0.32 1" contype="0" conaffinity="0"/>
    <body name="tracker" pos="{tp[0]} {tp[1]} {tp[2]}" quat="{' '.join(f'{v:.15g}' for v in tracker_quat)}">
      <geom name="tracker_head" type="box" size="0.08 0.06 0.1" rgba="0.85 0.85 0.8 1" contype="0" conaffinity="0"/>
    </body>
    <geom name="cone_a" type="cylinder" size="0.01 0.01" pos="{ca[0]} {ca[1]} {ca[2] - 0.01}" rgba="0.2 0.6 0.9 1" contype="0" conaffinity="0"/>
    <geom name="cone_b" type="cylinder" size="0.01 0.01" pos="{cb[0]} {cb[1]} {cb[2] - 0.01}" rgba="0.2 0.6 0.9 1" contype="0" conaffinity="0"/>
    <geom name="length_bar" type="capsule" fromto="{ca[0]} {ca[1]} {ca[2] - 0.02} {cb[0]} {cb[1]} {cb[2] - 0.02}" size="0.008" rgba="0.3 0.3 0.35 1" contype="0" conaffinity="0"/>
    <body name="base" pos="0 0 0">{body}{close}
    </body>
  </worldbody>
</mujoco>
"""
