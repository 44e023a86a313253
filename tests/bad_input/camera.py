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


def tiff_header(path, width=14000, height=14000, tile=0, compression=8):
    """A TIFF's header and one tiny strip (or tile): 16-bit RGBA, ``width`` x ``height``, and
    tiles of ``tile`` x ``tile`` where given. What the decoder allocates is what it declares."""
    import struct

    tags = {256: (4, width), 257: (4, height), 258: (3, 0x200), 259: (3, compression)}
    tags |= {262: (3, 2), 277: (3, 4), 284: (3, 1), 338: (3, 2)}
    if tile:
        tags |= {322: (4, tile), 323: (4, tile), 324: (4, 0x300), 325: (4, 64)}
    else:
        tags |= {273: (4, 0x300), 278: (4, height), 279: (4, 64)}
    ifd = struct.pack("<H", len(tags))
    for tag, (kind, value) in sorted(tags.items()):
        count = 4 if tag == 258 else 1
        if kind == 3 and count == 1:
            ifd += struct.pack("<HHIHH", tag, kind, count, value, 0)
        else:
            ifd += struct.pack("<HHII", tag, kind, count, value)
    data = bytearray(b"II*\x00" + struct.pack("<I", 8) + ifd + struct.pack("<I", 0))
    data += bytes(0x200 - len(data)) + struct.pack("<4H", 16, 16, 16, 16)
    data += bytes(0x300 - len(data)) + bytes(64)
    path.write_bytes(bytes(data))


def _png_header(width, height):
    """A PNG's signature, its header chunk and a first data chunk (libpng reads the header up
    to it, and checks each chunk's CRC), with almost no pixels."""
    import zlib

    def chunk(kind, data):
        return (
            len(data).to_bytes(4, "big") + kind + data + zlib.crc32(kind + data).to_bytes(4, "big")
        )

    ihdr = width.to_bytes(4, "big") + height.to_bytes(4, "big") + bytes([8, 0, 0, 0, 0])
    idat = zlib.compress(bytes(64))
    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", idat) + chunk(b"IEND", b"")


def filled_jpeg(path, side=9000):
    """A JPEG whose frame header says ``side`` x ``side``, one 0xFF fill byte before it (legal,
    and what a header parser that expects a marker at once misses)."""
    import cv2

    data = cv2.imencode(".jpg", np.zeros((8, 8), np.uint8))[1].tobytes()
    sof = data.index(b"\xff\xc0")
    size = side.to_bytes(2, "big")
    data = data[:sof] + b"\xff" + data[sof : sof + 5] + size + size + data[sof + 9 :]
    path.write_bytes(data)


def _jpeg2000(path):
    import cv2

    cv2.imwrite(str(path), np.zeros((64, 64), np.uint8))


def _tiny(path, side=7):
    import cv2

    cv2.imwrite(str(path), np.full((side, side), 128, np.uint8))


def _one(name):
    return ["camera", "{d}/" + name, "--cols", "9", "--rows", "6", "--square-mm", "25"]


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
        {"big.png": lambda p: p.write_bytes(_png_header(10000, 10000))},
        ["camera", "{d}/big.png", "--cols", "9", "--rows", "6", "--square-mm", "25"],
        2,
        "big.png: more than 32 megapixels, over the limit of what is decoded",
    ),
    (  # OpenCV's C int overflowed: exit 3
        "camera-cols-beyond-int",
        {},
        ["camera", "{d}/a.jpg", "--cols", "2147483648", "--rows", "6", "--square-mm", "25"],
        2,
        "3 to 1000 inner corners",
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
    # issue 62, item 3: one bound on decoded pixels, OpenCV's own, for every format
    (  # a 644 KB deflate TIFF of 14000 x 14000 decoded to 1.1 GB
        "camera-tiff-too-many-pixels",
        {"big.tiff": tiff_header},
        _one("big.tiff"),
        2,
        "big.tiff: more than 32 megapixels",
    ),
    (  # an 81-megapixel PGM took 1 GB
        "camera-pgm-too-many-pixels",
        {"big.pgm": b"P5\n9000 9000\n255\n" + bytes(64)},
        _one("big.pgm"),
        2,
        "big.pgm: more than 32 megapixels",
    ),
    (  # a fill byte before the frame header hid the size from the former header parser
        "camera-jpeg-fill-byte-too-many-pixels",
        {"fill.jpg": filled_jpeg},
        _one("fill.jpg"),
        2,
        "fill.jpg: more than 32 megapixels",
    ),
    (  # 16 x 16 pixels in tiles of 11520 x 11520: OpenCV allocated the tile, 550 MB
        "camera-tiff-huge-tiles",
        {"tiles.tiff": lambda p: tiff_header(p, 16, 16, tile=11520)},
        _one("tiles.tiff"),
        2,
        "declaring tiles of 11520 x 11520",
    ),
    (  # JPEG 2000, AVIF, HDR: 10-20 bytes a decoded pixel, not a photo format
        "camera-jpeg2000",
        {"a.jp2": _jpeg2000},
        _one("a.jp2"),
        2,
        "a.jp2: not a readable image",
    ),
    (  # item 7: OpenCV's adaptive threshold asserted (exit 3) on 14 px or less
        "camera-seven-pixels",
        {"tiny.png": _tiny},
        _one("tiny.png"),
        2,
        "tiny.png: 7 x 7 pixels: too small to show a chessboard",
    ),
    (  # OpenCV's detector refuses a pattern of 2 corners a way (exit 3)
        "camera-two-by-two",
        {"a.png": png},
        ["camera", "{d}/a.png", "--cols", "2", "--rows", "2", "--square-mm", "25"],
        2,
        "3 to 1000 inner corners each way",
    ),
]
