"""A branched robot for the tests (issue 63): a torso on a column carrying two 3-joint arms, its
chest's pitch coupled to the waist and the yaw (``follows``: no encoder of its own), each arm's
tool on its forearm; and the twin's springs: the waist's and the shoulders', the chest's lateral
flex."""

from __future__ import annotations

import numpy as np

STIFFNESS = (np.inf, 1e5, np.inf, 4e4, np.inf, np.inf, 4e4, np.inf, np.inf)  # N m / rad
FLEX = (np.inf, np.inf, 1e5, np.inf, np.inf, np.inf, np.inf, np.inf, np.inf)  # the chest's

# a_mm, d_mm, alpha_deg, mass_kg, com_mm, extra per joint: a column's yaw, the waist's pitch, the
# chest's pitch (following 0.25 q1 + 0.5 q2), then two 3-joint arms hung from the chest's ends
JOINTS = [
    (0.0, 600.0, -90.0, 12.0, (0.0, 150.0, 0.0), "range_deg = [-170.0, 170.0]\n"),
    (350.0, 0.0, 0.0, 8.0, (-175.0, 0.0, 0.0), "range_deg = [-40.0, 40.0]\n"),
    (250.0, 0.0, 0.0, 6.0, (-125.0, 0.0, 0.0), "follows = [[1, 0.25], [2, 0.5]]\n"),
    (0.0, 220.0, 90.0, 2.5, (0.0, 0.0, 0.0), "parent = 3\n"),
    (300.0, 0.0, 0.0, 2.0, (-150.0, 0.0, 0.0), ""),
    (250.0, 0.0, 0.0, 1.2, (-125.0, 0.0, 0.0), ""),
    (0.0, -220.0, 90.0, 2.5, (0.0, 0.0, 0.0), "parent = 3\n"),
    (300.0, 0.0, 0.0, 2.0, (-150.0, 0.0, 0.0), ""),
    (250.0, 0.0, 0.0, 1.2, (-125.0, 0.0, 0.0), ""),
]
TOOLS = [(6, (60.0, 0.0, 20.0)), (9, (60.0, 10.0, -20.0))]


def torso_toml() -> str:
    """The two-armed torso's ARM.toml."""
    text = 'name = "torso2"\nconvention = "dh"\n'
    for a, d, alpha, m, com, extra in JOINTS:
        text += (
            f"[[joint]]\na_mm = {a}\nd_mm = {d}\nalpha_deg = {alpha}\nmass_kg = {m}\n"
            f"com_mm = {list(com)}\n{extra}"
        )
    for joint, offset in TOOLS:
        text += f"[[tool]]\nparent = {joint}\noffset_mm = {list(offset)}\nmass_kg = 1.0\n"
    return text
