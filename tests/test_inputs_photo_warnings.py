"""A photo whose decoder warns (libpng writes "libpng warning: tEXt: CRC error" to the process's
stderr itself) still ends a command that refuses it in one line (issue 62, item 10)."""

import os
import struct
import subprocess
import sys

import cv2
import numpy as np


def _png_with_a_bad_chunk(path) -> None:
    """A 64 x 64 PNG with a text chunk whose CRC is wrong: libpng warns and decodes it."""
    ok, buf = cv2.imencode(".png", np.zeros((64, 64), np.uint8))
    b = buf.tobytes()
    data = b"Comment\x00hello"
    chunk = struct.pack(">I", len(data)) + b"tEXt" + data + b"\x00\x00\x00\x00"
    at = 8 + 25  # after the signature and the header chunk
    path.write_bytes(b[:at] + chunk + b[at:])


def test_a_decoder_s_warning_does_not_come_before_the_one_line(tmp_path):
    photos = [tmp_path / f"p{k}.png" for k in range(3)]
    for k, p in enumerate(photos):
        _png_with_a_bad_chunk(p)
        p.write_bytes(p.read_bytes() + bytes([k]))  # three photos, not one given thrice
    env = os.environ | {"CALIBENCH_PROGRESS": "off"}
    argv = ["camera", *map(str, photos), "--cols", "9", "--rows", "6", "--square-mm", "25"]
    p = subprocess.run(
        [sys.executable, "-m", "calibench.scenarios.cli", *argv, "--out", str(tmp_path / "o")],
        capture_output=True,
        text=True,
        env=env,
        timeout=120,
    )
    assert p.returncode == 2, p.stderr
    assert len(p.stderr.strip().splitlines()) == 1, p.stderr
    assert "no 9x6 chessboard found" in p.stderr
