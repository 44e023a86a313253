"""The virtual world: as-built truth, MuJoCo state, sensors -> Recording (+ Truth, kept apart).

MuJoCo must see ``MUJOCO_GL`` before its first import for offscreen rendering on the CPU.
"""

import os

os.environ.setdefault("MUJOCO_GL", "egl")
