"""Issue 62, item 7: MUJOCO_GL garbage, glfw, osmesa or empty on a rendered run was exit 3 (an
import's RuntimeError, PyOpenGL's AttributeError, MuJoCo's FatalError); each is now one line,
exit 2, saying what to set."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from calibench.scenarios.config import check_mujoco_gl
from calibench.scenarios.report import BadInput


@pytest.mark.parametrize(
    "value, renders, said",
    [
        ("garbage", False, "is not a MuJoCo GL backend"),
        ("garbage", True, "is not a MuJoCo GL backend"),
        ("glfw", True, "no display"),
        ("", True, "no display"),
        ("disable", True, "disables rendering"),
    ],
)
def test_a_backend_that_cannot_render_here_is_said(monkeypatch, value, renders, said):
    monkeypatch.setenv("MUJOCO_GL", value)
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    with pytest.raises(BadInput, match=said) as e:
        check_mujoco_gl(renders)
    assert "MUJOCO_GL=egl" in str(e.value)


@pytest.mark.parametrize("value", ["egl", "EGL ", "glfw", "", "disable"])
def test_a_backend_is_fine_where_nothing_renders(monkeypatch, value):
    monkeypatch.setenv("MUJOCO_GL", value)
    check_mujoco_gl(renders=value.strip().lower() == "egl")


def test_osmesa_without_its_library_is_said(monkeypatch):
    import ctypes.util

    monkeypatch.setenv("MUJOCO_GL", "osmesa")
    monkeypatch.setattr(ctypes.util, "find_library", lambda name: None)
    with pytest.raises(BadInput, match="OSMesa library is not installed"):
        check_mujoco_gl()


def test_a_context_that_cannot_be_made_is_bad_input(monkeypatch):
    """Whatever still fails where the first context is made is said as the environment's."""
    import mujoco

    from calibench.sim import offscreen

    def fail(width, height):
        raise AttributeError("'NoneType' object has no attribute 'glGetError'")

    monkeypatch.setattr(offscreen, "_gl_context", fail)
    model = mujoco.MjModel.from_xml_string("<mujoco><worldbody/></mujoco>")
    with pytest.raises(
        BadInput, match="cannot render offscreen with MUJOCO_GL=.*set MUJOCO_GL=egl"
    ):
        offscreen.Offscreen(model)


@pytest.mark.parametrize("value", ["glfw", "disable", "garbage", ""])  # osmesa: where installed
def test_a_rendered_run_without_a_usable_backend_ends_in_bad_input(tmp_path, value):
    """The command itself, in a process of its own (MuJoCo reads MUJOCO_GL as it loads)."""
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    env |= {"MUJOCO_GL": value, "CALIBENCH_PROGRESS": "off"}
    p = subprocess.run(
        [sys.executable, "-m", "calibench.scenarios.cli", "run", "belt-stage", "--no-rrd"]
        + ["--out", str(tmp_path / "o")],
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
    )
    assert p.returncode == 2, p.stderr
    assert "Traceback" not in p.stderr
    assert len(p.stderr.strip().splitlines()) == 1, p.stderr
    assert "set MUJOCO_GL=egl" in p.stderr, p.stderr
