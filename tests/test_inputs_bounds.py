"""Issue 62's bounds on what one input may cost: an image's decoded pixels (OpenCV's own limit,
set before cv2 loads) and a CSV line's length, each measured as the peak memory of a real
command in its own process."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from tests.bad_input.camera import filled_jpeg, tiff_header

MB = 1024  # ru_maxrss is in KiB on Linux
LIMIT_KB = 600 * MB


def _command(args: list[str], cwd: Path, timeout: float = 120) -> tuple[int, str, int]:
    """(exit status, stderr, the command's peak memory in KiB), the command alone in a process
    of its own (a fresh interpreter: its children's peak is its own)."""
    code = (
        "import resource, subprocess, sys\n"
        "p = subprocess.run([sys.executable, '-m', 'calibench.scenarios.cli', *sys.argv[1:]],"
        " stderr=subprocess.PIPE, text=True)\n"
        "sys.stderr.write(p.stderr)\n"
        "print(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss)\n"
        "sys.exit(p.returncode)\n"
    )
    env = {**os.environ, "MUJOCO_GL": "egl", "CALIBENCH_PROGRESS": "off"}
    p = subprocess.run(
        [sys.executable, "-c", code, *args],
        cwd=cwd,
        capture_output=True,
        text=True,
        env=env,
        timeout=timeout,
    )
    return p.returncode, p.stderr.strip(), int(p.stdout.strip().splitlines()[-1])


@pytest.mark.parametrize(
    "name, make",
    [
        ("big.tiff", tiff_header),  # a deflate TIFF of 14000 x 14000 px: 1.1 GB decoded
        ("fill.jpg", filled_jpeg),  # 9000 x 9000, a fill byte before the frame header
        ("big.pgm", lambda p: p.write_bytes(b"P5\n9000 9000\n255\n" + bytes(81_000_000))),
        ("tiles.tiff", lambda p: tiff_header(p, 16, 16, tile=11520)),  # OpenCV allocated a tile
    ],
)
def test_an_image_over_the_bound_is_refused_in_one_line_under_600_mb(tmp_path, name, make):
    make(tmp_path / name)
    args = ["camera", name, "--cols", "9", "--rows", "6", "--square-mm", "25", "--out", "o"]
    status, err, peak = _command(args, tmp_path)
    assert status == 2 and len(err.splitlines()) == 1, err
    assert name in err and ("megapixels" in err or "tiles" in err), err
    assert peak < LIMIT_KB, f"{peak / MB:.0f} MB"


def test_opencv_loaded_before_calibench_is_said_not_decoded_unbounded(tmp_path):
    """OpenCV reads its limit once, as cv2 loads: a program that imported cv2 first would decode
    a gigapixel. The reader then refuses to decode at all (an internal error, not a silent
    gigabyte)."""
    code = (
        "import cv2\n"
        "from calibench.scenarios.camera import decoding_is_bounded\n"
        "try:\n    decoding_is_bounded()\nexcept RuntimeError as e:\n    print(e)\n"
    )
    env = {k: v for k, v in os.environ.items() if k != "OPENCV_IO_MAX_IMAGE_PIXELS"}
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=60
    )
    assert "import calibench before cv2" in out.stdout, out.stdout + out.stderr


def test_this_process_decodes_under_the_bound():
    """The tests' own process (tests/conftest.py imports calibench before cv2) is bounded."""
    from calibench.scenarios.camera import decoding_is_bounded

    decoding_is_bounded()  # raises where it is not


def test_a_line_of_fifty_million_commas_is_refused_in_bounded_memory(tmp_path):
    """A header, one row and 50 million commas: exit 0 at 916 MB before; now one line, read no
    further than the bound on a line."""
    with open(tmp_path / "r.csv", "w") as f:
        f.write("x_cmd_mm,y_cmd_mm,x_meas_mm,y_meas_mm\n1,2,3,4")
        for _ in range(50):
            f.write("," * 1_000_000)
        f.write("\n")
    status, err, peak = _command(["fit", "belt-stage", "r.csv", "--out", "o"], tmp_path)
    assert status == 2 and len(err.splitlines()) == 1, err
    assert "r.csv line 2: over 100,000 characters" in err, err
    assert peak < LIMIT_KB, f"{peak / MB:.0f} MB"


@pytest.mark.parametrize("verb", [["fit", "belt-stage"], ["iso230"], ["discover", "belt-stage"]])
def test_dev_zero_is_refused_in_bounded_memory(tmp_path, verb):
    """A file without a line end that never ends: `fit belt-stage /dev/zero` grew without bound."""
    status, err, peak = _command([*verb, "/dev/zero", "--out", "o"], tmp_path)
    assert status == 2 and len(err.splitlines()) == 1, err
    assert "/dev/zero" in err, err
    assert peak < LIMIT_KB, f"{peak / MB:.0f} MB"
