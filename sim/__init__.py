"""The virtual world: as-built truth, MuJoCo state, sensors -> Recording (+ Truth, kept apart).

Rendering on a machine without a display needs ``MUJOCO_GL=egl`` in the environment before
MuJoCo's first import (MuJoCo reads it then). The ``calibench`` command and its worker processes
set it; in a script or notebook, set it yourself first (``os.environ["MUJOCO_GL"] = "egl"``).
Importing this package changes nothing global.
"""
