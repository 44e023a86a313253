"""Scenario configuration: frozen dataclasses with defaults, overridden from a TOML table.

A config file holds one table per scenario, nested as the dataclasses are::

    [belt-stage]
    n_intrinsic_views = 25
    [belt-stage.truth]
    board_yaw_rad = 0.002
    [belt-stage.geometry.camera]
    k1 = -0.2
"""

from __future__ import annotations

import dataclasses
import math
import tomllib
from pathlib import Path
from typing import Any

import numpy as np

from calibench.scenarios.report import BadInput

# Ranges by what a key names, so that every scenario's config is checked the same way.
# Counts (int): at least 1, at most MAX_COUNT (a typo of 1e9 postures is refused before any work).
MAX_COUNT = 100_000
MIN_COUNT = {
    "cols": 2,
    "rows": 2,
    "n": 3,
    "runs": 2,
    "targets_per_line": 2,
    "samples_per_turn": 8,
    "width": 16,
    "height": 16,
    "align_max_turns": 0,
    # the probe scanner judges its paper's method by the method's scatter over these turns
    "sweep_turns": 5,
}
MAX_PIXELS = 8192  # a camera side
# Lists that are a point, a pair or a model's coefficients (other lists: as long as you like)
FIXED_LENGTH = {
    "travel_mm",
    "error_x",
    "error_y",
    "centre_mm",
    "plate_centre_mm",
    "tracker_pos_mm",
    "tracker_tilt_rad",
    "cone_a_mm",
    "cone_b_mm",
    "range_noise_um",
    "reversal_um",
    "length_noise_um",
    "plate_origin_reading_mm",
    "x_guide_ref_mm",
    "y_guide_ref_mm",
    "grid",
    "m_sweep",
    "stated_range_sigma_um",
    "stated_length_sigma_um",
}
# Floats that are scatters, limits or sizes: a negative one is a typo, not a physics.
NONNEGATIVE = (
    "noise",
    "sigma",
    "jitter",
    "limit",
    "tolerance",
    "repeatability",
    "quantum",
    "psf",
    "seat",
    "error_um",
    "aim_um",
    "reversal_um",
    "contour_quanta",
    "requirement",
    # physics MuJoCo refuses negative (masses, inertias, densities) and a leg that would
    # shorten under load, or a radius below zero
    "mass",
    "inertia",
    "density",
    "compliance",
    "radius",
    "margin",
)
POSITIVE = (
    "square_mm",
    "pitch_mm",
    "diameter_mm",
    "fx",
    "fy",
    "working_distance_mm",
    "camera_height_mm",
    "period",
    "half_side_mm",
    "rail_length_mm",
    "A_mm",
    "B_mm",
    "travel_mm",
    "home_height_mm",
    "translation_mm",
    "rotation_deg",
    "p",
    "reading_sigma_um",
    "angle_sigma_urad",
    "kg",  # a moving body's mass: MuJoCo needs it above zero
    # a weight's 1-sigma (zero: an infinite weight), a quantisation step, a servo's tolerance
    # (zero: it never settles)
    "bar_sigma_mm",
    "quantum_um",
    "servo_tolerance_px",
)
# Scatters beyond anything the instrument could be: a detector's corner noise of 10 px is no
# detector (the estimators then fail for reasons no message could name).
AT_MOST = {"noise_px": 10.0}


def load_toml(path: str | Path) -> dict:
    """A TOML file as nested dicts; BadInput naming the file when it cannot be read or parsed.
    A UTF-8 byte-order mark (what Windows editors write) is read past: TOML forbids it, and the
    file is UTF-8 all the same."""
    try:
        with open(path, "rb") as f:
            data = f.read()
        return tomllib.loads(data.removeprefix(b"\xef\xbb\xbf").decode("utf-8"))
    except OSError as e:
        raise BadInput(f"cannot read config {path}: {e.strerror}") from None
    except UnicodeDecodeError:
        raise BadInput(f"config {path} is not valid TOML: not UTF-8 text") from None
    except tomllib.TOMLDecodeError as e:
        raise BadInput(f"config {path} is not valid TOML: {e}") from None
    except RecursionError:
        raise BadInput(
            f"config {path} is nested too deep to read (thousands of levels): not a config"
        ) from None


def check_tables(path: str | Path, doc: dict, chosen: list[str], known: list[str]) -> None:
    """BadInput when the config ``doc`` (read from ``path``) has a table of an unknown name, or
    only other scenarios' tables than ``chosen``'s, which would be ignored without a word (``run
    vision-stage`` with only a ``[belt-stage]`` table ran the defaults). A file with a table for
    each of several scenarios (examples/conceal.toml) serves any of them. ``known``: every
    scenario's name."""
    unknown = [k for k in doc if k not in known]
    if unknown:
        raise BadInput(f"config {path}: unknown scenario table(s) {', '.join(unknown)}")
    other = [k for k in doc if k not in chosen]
    if other and not any(c in doc for c in chosen):
        raise BadInput(
            f"config {path}: a run of {', '.join(chosen)} takes only its "
            f"{', '.join(f'[{c}]' for c in chosen)} table (found [{'], ['.join(other)}], which "
            "it would ignore)"
        )


def override(obj: Any, table: dict, where: str) -> Any:
    """A copy of dataclass ``obj`` with the keys of ``table`` replaced, recursively."""
    if not isinstance(table, dict):  # [[scenario]], an array of tables, or a bare value
        kind = "an array of tables ([[...]])" if isinstance(table, list) else repr(table)
        raise BadInput(f"config: {where} must be one table ([{where}]), not {kind}")
    names = {f.name for f in dataclasses.fields(obj)}
    changes = {}
    for key, value in table.items():
        if key not in names:
            raise BadInput(f"config: unknown key {where}.{key} (known: {', '.join(sorted(names))})")
        current = getattr(obj, key)
        if dataclasses.is_dataclass(current):
            if not isinstance(value, dict):
                raise BadInput(f"config: {where}.{key} must be a table")
            changes[key] = override(current, value, f"{where}.{key}")
        else:
            changes[key] = _coerce(current, value, f"{where}.{key}")
    try:
        return dataclasses.replace(obj, **changes)
    except BadInput as e:
        if str(e).startswith("config: "):  # a config class's own check, which names its key
            raise
        raise BadInput(f"config: {where}: {e}") from None
    except (TypeError, ValueError) as e:
        raise BadInput(f"config: {where}: {e}") from None


def _number(value: Any, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise BadInput(f"config: {where} must be a number, not {value!r}")
    if math.isnan(value) or (math.isinf(value) and "stiffness" not in where):  # inf: a rigid joint
        raise BadInput(f"config: {where} is {value}: a finite number please")
    return value


def _check_range(key: str, value: float, where: str) -> None:
    if any(w in key for w in NONNEGATIVE) and value < 0:
        raise BadInput(f"config: {where} = {value}: must be zero or positive")
    if (key in POSITIVE or key.endswith(tuple("_" + w for w in POSITIVE))) and value <= 0:
        raise BadInput(f"config: {where} = {value}: must be positive")
    for end, most in AT_MOST.items():
        if key.endswith(end) and value > most:
            raise BadInput(f"config: {where} = {value}: at most {most:g}")


def _coerce(current: Any, value: Any, where: str) -> Any:
    key = where.rsplit(".", 1)[-1]
    if isinstance(current, bool):
        if not isinstance(value, bool):
            raise BadInput(f"config: {where} must be true or false")
        return value
    if isinstance(current, int):
        v = _number(value, where)
        if not float(v).is_integer():
            raise BadInput(f"config: {where} = {v}: must be a whole number")
        v = int(v)
        lo = MIN_COUNT.get(key, 1)
        hi = MAX_PIXELS if key in ("width", "height") else MAX_COUNT
        if not lo <= v <= hi:
            raise BadInput(f"config: {where} = {v}: must be between {lo} and {hi}")
        return v
    if isinstance(current, float):
        v = float(_number(value, where))
        _check_range(key, v, where)
        return v
    if isinstance(current, (tuple, np.ndarray)):
        if not isinstance(value, list):
            raise BadInput(f"config: {where} must be a list")
        flat: np.ndarray | list = np.asarray(value, dtype=object).ravel() if value else []
        for x in flat:
            if isinstance(x, list):
                raise BadInput(f"config: {where}: rows of different lengths")
            _number(x, where)
            _check_range(key, float(x), where)
        if (
            isinstance(current, tuple)
            and current
            and all(isinstance(c, int) and not isinstance(c, bool) for c in current)
        ):
            if not all(float(x).is_integer() for x in flat):
                raise BadInput(f"config: {where} takes whole numbers")
            value = [int(x) for x in value]
        if isinstance(current, np.ndarray):
            arr = np.asarray(value, float)
            if arr.shape != current.shape:
                raise BadInput(f"config: {where} has shape {arr.shape}, expected {current.shape}")
            return arr
        if key in FIXED_LENGTH and len(value) != len(current):
            raise BadInput(f"config: {where} has {len(value)} values, expected {len(current)}")
        return tuple(value)
    if isinstance(current, str) and not isinstance(value, str):
        raise BadInput(f"config: {where} must be a string")
    return value


# --- checks across keys, shared by the scenarios' config classes (their __post_init__) ---------
def show(value: Any) -> str:
    """A config value as the line quoting it shows it: numbers in %g, lists as lists, short."""
    if isinstance(value, (bool, str)):
        return repr(value)
    if isinstance(value, (int, float, np.integer, np.floating)):
        return f"{float(value):g}" if isinstance(value, (float, np.floating)) else str(int(value))
    arr = np.asarray(value, dtype=float)
    text = np.array2string(
        arr,
        separator=", ",
        formatter={"float_kind": lambda x: f"{x:g}"},
        threshold=12,
        max_line_width=10_000,
    ).replace("\n", "")
    return text if len(text) <= 80 else text[:77] + "..."


def bad(where: str, value: Any, why: str) -> BadInput:
    """The one line of a config value that cannot be used: its key, its value, why and the range."""
    return BadInput(f"config: {where} = {show(value)}: {why}")


# A lens's radial displacement over the image, relative to the distance from the principal point:
# OpenCV's five-coefficient model is calibrated on lenses that bend the image's corners by tens of
# per cent at most; beyond that (or a lens that folds the image back) no calibration view is
# placed and no calibration converges.
MAX_LENS_BEND = 0.3


def check_camera(cam, where: str) -> None:
    """A :class:`~calibench.scenes.camera.PinholeCamera`'s principal point in the middle half of
    its image, and a lens that bends the image by at most MAX_LENS_BEND and one-to-one."""
    for name, c, size in (("cx", cam.cx, cam.width), ("cy", cam.cy, cam.height)):
        lo, hi = (size - 1) / 2 - size / 4, (size - 1) / 2 + size / 4
        if not lo <= c <= hi:
            raise bad(
                f"{where}.{name}",
                c,
                f"the principal point lies near the middle of the {size} px image: "
                f"{name} from {lo:g} to {hi:g}",
            )
    # the image's extent in normalised coordinates, a grid over it (corners included)
    u = np.linspace(-cam.cx / cam.fx, (cam.width - 1 - cam.cx) / cam.fx, 33)
    v = np.linspace(-cam.cy / cam.fy, (cam.height - 1 - cam.cy) / cam.fy, 33)
    xy = np.stack(np.meshgrid(u, v), axis=-1).reshape(-1, 2)
    with np.errstate(all="ignore"):
        d = cam.distort_normalized(xy)
        r = np.linalg.norm(xy, axis=1)
        bend = np.max(np.linalg.norm(d - xy, axis=1)[r > 0] / r[r > 0])
        h = 1e-6
        jx = (cam.distort_normalized(xy + [h, 0]) - cam.distort_normalized(xy - [h, 0])) / (2 * h)
        jy = (cam.distort_normalized(xy + [0, h]) - cam.distort_normalized(xy - [0, h])) / (2 * h)
        det = jx[:, 0] * jy[:, 1] - jx[:, 1] * jy[:, 0]
    if not (np.isfinite(bend) and bend <= MAX_LENS_BEND and np.all(det > 0)):
        lens = ", ".join(f"{k} = {getattr(cam, k):g}" for k in ("k1", "k2", "p1", "p2", "k3"))
        how = (
            f"moves the image's points by up to {bend:.3g} of their distance from the principal "
            "point"
            if np.isfinite(bend)
            else "is not finite over the image"
        )
        raise BadInput(
            f"config: {where}: the lens {lens} "
            f"{how}{'' if np.all(det > 0) else ' and folds the image'}"
            f": a calibratable lens bends them by at most {MAX_LENS_BEND:.0%}, one-to-one"
        )


# MuJoCo's own GL backends on Linux (mujoco/rendering/classic/gl_context.py): any other value of
# MUJOCO_GL makes ``import mujoco`` itself raise, whatever the command
GL_OFF = ("disable", "disabled", "off", "false", "0")
GL_WINDOWED = ("enable", "enabled", "on", "true", "1", "glfw", "", "glx")  # need a display
MUJOCO_GL_VALUES = GL_OFF + GL_WINDOWED + ("egl", "osmesa")


def check_mujoco_gl(renders: bool = False) -> None:
    """BadInput when the environment's ``MUJOCO_GL`` is no backend MuJoCo knows, or OSMesa
    without its library: ``import mujoco`` would raise (an internal error's exit 3). With
    ``renders`` (a command that will render), also a backend that renders nothing here:
    rendering disabled, or a window system's (GLFW, GLX) without a display. Call it before MuJoCo
    is first imported; what still fails is said where the first context is made
    (:func:`calibench.sim.offscreen.no_gl_context`)."""
    import os

    said = os.environ.get("MUJOCO_GL")
    if said is None:
        return
    value = said.lower().strip()
    if renders and value in GL_OFF:
        raise BadInput(
            f"MUJOCO_GL={said!r} disables rendering, and this run renders: set MUJOCO_GL=egl "
            "(Mesa renders offscreen on the CPU, no display needed), or run with --fidelity "
            "analytic"
        )
    windowed = value in MUJOCO_GL_VALUES[5:13] or value == "glx"
    if (
        renders
        and windowed
        and not (os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))
    ):
        raise BadInput(
            f"MUJOCO_GL={said!r} renders through a window system, and there is no display "
            "(DISPLAY is not set): set MUJOCO_GL=egl (Mesa renders offscreen on the CPU), or run "
            "with --fidelity analytic"
        )
    if value not in MUJOCO_GL_VALUES:
        raise BadInput(
            f"MUJOCO_GL={said!r} is not a MuJoCo GL backend: set MUJOCO_GL=egl (Mesa renders "
            "offscreen on the CPU, no display needed), or osmesa or glfw where those work"
        )
    if value == "osmesa":
        import ctypes.util

        # PyOpenGL loads the library as MuJoCo is imported, and fails there without it
        if ctypes.util.find_library("OSMesa") is None:
            raise BadInput(
                "MUJOCO_GL='osmesa' but the OSMesa library is not installed: set MUJOCO_GL=egl "
                "(Mesa renders offscreen on the CPU, no display needed), or install libosmesa"
            )
