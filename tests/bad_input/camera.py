"""Bad-input cases, `camera`: photos and board sizes it must refuse.

See tests/test_bad_input.py, which runs every case.
"""

from __future__ import annotations

import numpy as np


def png(path, size=(480, 640), value=128):
    import cv2

    cv2.imwrite(str(path), np.full((*size, 3), value, np.uint8))
    return path


def board_png(path, squares=(10, 7), px=40):
    """A flat chessboard of ``squares`` (columns, rows) squares, ``px`` pixels each, on white."""
    import cv2

    i, j = np.indices((squares[1] * px, squares[0] * px)) // px
    board = np.where((i + j) % 2 == 0, 0, 255).astype(np.uint8)
    cv2.imwrite(str(path), cv2.copyMakeBorder(board, 60, 60, 60, 60, cv2.BORDER_CONSTANT, 255))
    return path


def _truncated_jpeg(path):
    import cv2

    img = np.random.default_rng(0).integers(0, 255, (240, 320, 3), np.uint8)
    data = cv2.imencode(".jpg", img)[1].tobytes()
    path.write_bytes(data[: len(data) // 2])


# (id, files to write {name: text or bytes or callable(path)}, argv with {d} for the case folder,
#  expected exit status, a fragment the message must contain)
CASES = [
    # camera
    (  # a 10 x 7 board of squares given as its squares: it has 9 x 6 inner corners
        "camera-board-counted-in-squares",
        {f"b{k}.png": board_png for k in range(3)},
        ["camera", "{d}/b0.png", "{d}/b1.png", "{d}/b2.png", "--cols", "10", "--rows", "7"]
        + ["--square-mm", "25"],
        2,
        "--cols and --rows count inner corners",
    ),
    (
        "camera-folder",
        {"photos/a.txt": "x"},
        ["camera", "{d}/photos", "--cols", "9", "--rows", "6", "--square-mm", "25"],
        2,
        "a folder, not an image",
    ),
    (
        "camera-symlink-loop",
        {"loop.jpg": lambda p: p.symlink_to(p.name)},
        ["camera", "{d}/loop.jpg", "--cols", "9", "--rows", "6", "--square-mm", "25"],
        2,
        "a symbolic link that leads nowhere",
    ),
    (  # a 10000 x 10000 photo (its header: nothing to decode): refused before decoding
        "camera-too-many-pixels",
        {
            "big.png": b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR"
            + (10000).to_bytes(4, "big") * 2
            + b"\x08\x00\x00\x00\x00\x00\x00\x00\x00"
        },
        ["camera", "{d}/big.png", "--cols", "9", "--rows", "6", "--square-mm", "25"],
        2,
        "10000 x 10000 pixels, over the 50-megapixel limit",
    ),
    (  # OpenCV's C int overflowed: exit 3
        "camera-cols-beyond-int",
        {},
        ["camera", "{d}/a.jpg", "--cols", "2147483648", "--rows", "6", "--square-mm", "25"],
        2,
        "2 to 1000 inner corners",
    ),
    (
        "camera-no-image",
        {},
        ["camera", "{d}/none.jpg", "--cols", "9", "--rows", "6", "--square-mm", "25"],
        2,
        "no such image",
    ),
    (
        "camera-not-image",
        {"a.jpg": "not an image"},
        [
            "camera",
            "{d}/a.jpg",
            "--cols",
            "9",
            "--rows",
            "6",
            "--square-mm",
            "25",
            "--out",
            "{d}/o",
        ],
        2,
        "a.jpg: not a readable image",
    ),
    (
        "camera-no-board",
        {"a.png": png, "b.png": png, "c.png": png},
        [
            "camera",
            "{d}/a.png",
            "{d}/b.png",
            "{d}/c.png",
            "--cols",
            "9",
            "--rows",
            "6",
            "--square-mm",
            "25",
            "--out",
            "{d}/o",
        ],
        2,
        "board",
    ),
    (
        "camera-cols-zero",
        {"a.png": png},
        ["camera", "{d}/a.png", "--cols", "0", "--rows", "6", "--square-mm", "25"],
        2,
        "--cols",
    ),
    (
        "camera-rows-negative",
        {"a.png": png},
        ["camera", "{d}/a.png", "--cols", "9", "--rows", "-6", "--square-mm", "25"],
        2,
        "--rows",
    ),
    (
        "camera-square-zero",
        {"a.png": png},
        ["camera", "{d}/a.png", "--cols", "9", "--rows", "6", "--square-mm", "0"],
        2,
        "--square-mm",
    ),
    (
        "camera-square-nan",
        {"a.png": png},
        ["camera", "{d}/a.png", "--cols", "9", "--rows", "6", "--square-mm", "nan"],
        2,
        "--square-mm",
    ),
    (
        "camera-square-text",
        {"a.png": png},
        ["camera", "{d}/a.png", "--cols", "9", "--rows", "6", "--square-mm", "big"],
        2,
        "--square-mm",
    ),
    (
        "camera-square-absurd",
        {"a.png": png},
        ["camera", "{d}/a.png", "--cols", "9", "--rows", "6", "--square-mm", "1e-300"],
        2,
        "from 0.001 to 10000 mm",
    ),
    (
        "camera-truncated-jpeg",
        {"a.jpg": lambda p: _truncated_jpeg(p)},
        [
            "camera",
            "{d}/a.jpg",
            "--cols",
            "9",
            "--rows",
            "6",
            "--square-mm",
            "25",
            "--out",
            "{d}/o",
        ],
        2,
        "a.jpg: not a readable image (truncated",
    ),
    (
        "camera-same-file-twice",
        {"a.png": png},
        ["camera", "{d}/a.png", "{d}/a.png", "--cols", "9", "--rows", "6", "--square-mm", "25"],
        2,
        "is given twice",
    ),
    (
        "camera-radial-4",
        {"a.png": png},
        ["camera", "{d}/a.png", "--cols", "9", "--rows", "6", "--square-mm", "25", "--radial", "4"],
        2,
        "invalid choice",
    ),
    (
        "camera-out-is-file",
        {"a.png": png, "f.txt": "x"},
        [
            "camera",
            "{d}/a.png",
            "--cols",
            "9",
            "--rows",
            "6",
            "--square-mm",
            "25",
            "--out",
            "{d}/f.txt",
        ],
        2,
        "is a file",
    ),
]
