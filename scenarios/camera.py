"""``calibench camera``: calibrate a camera from real chessboard photos (docs/formats.md:
intrinsics.json)."""

from __future__ import annotations

import contextlib
import json
import os
import sys
import tempfile
import threading
from collections.abc import Iterator
from pathlib import Path

import cv2
import numpy as np

from calibench import MAX_IMAGE_PIXELS
from calibench.estimators.camera.board_extent import seeming_size
from calibench.estimators.camera.chessboard import find_chessboard_corners, gross_corners
from calibench.estimators.camera.zhang import CalibrationError, calibrate_camera
from calibench.files import first_repeat
from calibench.scenarios.camera_figure import coverage, write_camera_figure
from calibench.scenarios.cvplot import warm_fonts
from calibench.scenarios.progress import advance
from calibench.scenarios.report import BadInput
from calibench.scenes.checkerboard import Chessboard
from calibench.writing import write_text


def calibrate_photos(
    paths: list[Path],
    cols: int,
    rows: int,
    square_mm: float,
    fix_aspect: bool = False,
    radial: int = 3,
    tangential: bool = True,
    corners_out: dict | None = None,
) -> dict:
    """Detect the board in every photo, calibrate on those where it is found.

    ``corners_out``, when given, receives each used photo's corners, (cols * rows, 2) px (NaN
    where left out), by the photo's name."""
    # OpenCV's chessboard detector refuses a pattern of 2 inner corners a way (an assertion)
    if cols < 3 or rows < 3 or square_mm <= 0:
        raise BadInput("camera: --cols and --rows must be >= 3 and --square-mm > 0")
    if radial not in (2, 3):
        raise BadInput("camera: --radial must be 2 or 3")
    for p in paths:
        if not p.is_file():
            raise BadInput(f"camera: {p}: {_not_a_file(p)}")
    twice = first_repeat(paths)
    if twice is not None:
        raise BadInput(f"camera: {twice} is given twice: a photo counts once")
    names = _labels(paths)
    found, sizes, rejected, bigger = {}, {}, {}, {}
    for p, (size, corners, why, seems) in zip(paths, _detect_all(paths, cols, rows)):
        if size is None:
            rejected[names[p]] = why
            continue
        sizes[p], found[p] = size, corners
        if seems is not None and seems != (cols, rows):
            bigger[names[p]] = seems
    _refuse_a_part_of_the_board(bigger, sum(c is not None for c in found.values()), cols, rows)
    # the size most photos share is the camera's: one odd photo, first or not, is the one rejected
    counts = list(sizes.values())
    size = max(set(counts), key=counts.count) if counts else None
    used: list[str] = []
    points: list[np.ndarray] = []
    left_out: dict[str, list[dict]] = {}
    for p, corners in found.items():
        if sizes[p] != size:
            assert size is not None  # found and sizes share their photos: there is a size
            rejected[names[p]] = (
                f"size {sizes[p][0]}x{sizes[p][1]} differs from the others' {size[0]}x{size[1]}"
            )
            continue
        if corners is None:
            rejected[names[p]] = f"no {cols}x{rows} chessboard found"
            continue
        # the same view twice adds no information but would count as a constraint: left out
        same = next((u for u, c in zip(used, points) if np.nanmax(np.abs(c - corners)) < 0.5), None)
        if same is not None:
            rejected[names[p]] = f"the same view as {same} (corners within 0.5 px)"
            continue
        # a detector's gross error (pixels off the board's grid) would pull the whole calibration:
        # the corner is left out of its view and named
        gross = gross_corners(corners, cols, rows)
        if gross:
            corners = corners.copy()
            corners[[k for k, _ in gross]] = np.nan
            left_out[names[p]] = [{"corner": k, "off_grid_px": round(r, 2)} for k, r in gross]
        used.append(names[p])
        points.append(corners)
    if len(used) < 3:
        no_board = found and all(c is None for c in found.values())
        why = "; ".join(f"{k}: {v}" for k, v in list(rejected.items())[:3])
        more = f" and {len(rejected) - 3} more" if len(rejected) > 3 else ""
        raise BadInput(
            f"camera: {len(used)} usable view(s) of the {cols}x{rows} board among {len(paths)} "
            "image(s), "
            f"a calibration needs at least 3 distinct ones"
            + (f" ({why}{more})" if why else "")
            + (
                _COUNT_INNER.format(cols=cols, rows=rows, c=cols - 1, r=rows - 1)
                if no_board
                else ""
            )
        )
    board = Chessboard(cols=cols, rows=rows, square_mm=square_mm)
    try:
        calib = calibrate_camera(
            board.corners_mm(),
            points,
            size,
            fix_aspect=fix_aspect,
            fix_k3=radial < 3,
            tangential=tangential,
        )
    except CalibrationError as e:
        remedy = _NOT_CONVERGED if "did not converge" in str(e) else ""
        raise BadInput(f"camera: {e}{remedy}") from None
    except cv2.error as e:  # OpenCV's own assertions on degenerate view sets
        raise BadInput(
            f"camera: the views are degenerate for calibration (OpenCV: "
            f"{str(e).strip().splitlines()[-1][:120]}): tilt the board differently in each photo"
        ) from None
    if corners_out is not None:
        corners_out.update(zip(used, points))
    dist = calib.dist.ravel().tolist()
    return {
        "image_size": list(size),
        "K": calib.K.tolist(),
        "dist": dist,
        "distortion": dict(zip(DIST_NAMES, dist)),
        "std": calib.std,
        "rms_px": calib.rms_px,
        "per_view_rms_px": dict(zip(used, map(float, calib.per_view_rms_px))),
        "used": used,
        "rejected": rejected,
        "corners_left_out": left_out,
        "model": {"fix_aspect": fix_aspect, "radial": radial, "tangential": tangential},
    }


def _refuse_a_part_of_the_board(bigger: dict, found: int, cols: int, rows: int) -> None:
    """BadInput where the board has more inner corners than --cols and --rows say: a
    calibration on a part of it would take another board's corners for this one's.

    ``bigger``: the size (cols, rows) each photo's board seems to have where it shows more
    corners than the grid found; ``found``: the photos where a grid was found. Half of them
    showing more is the board, not a stray pattern beside it."""
    if not bigger or 2 * len(bigger) < found:
        return
    sizes = list(bigger.values())
    c, r = max(set(sizes), key=lambda s: (sizes.count(s), s))
    raise BadInput(
        f"camera: the board has more inner corners than --cols {cols} --rows {rows}: "
        f"{len(bigger)} of the {found} photos where a {cols}x{rows} grid was found show corners "
        f"beyond it or between its lines ({', '.join(list(bigger)[:3])}"
        f"{'...' if len(bigger) > 3 else ''}); it seems to have {c}x{r}: give --cols {c} --rows {r}"
    )


def _detect_all(paths: list[Path], cols: int, rows: int) -> list[tuple]:
    """Each photo's (size (w, h), corners or None, "", the size its board seems to have
    (:func:`seeming_size`) or None) or (None, None, why it is refused, None), in order. A photo
    per core at a time (OpenCV's decoding and detection release the GIL), only its corners
    kept: memory stays that of a few photos."""

    out: list = [None] * len(paths)
    failed: list[BaseException] = []
    one_large = threading.Lock()

    def detect(every: int, first: int) -> None:
        try:
            for k in range(first, len(paths), every):
                img, why = _read_gray(paths[k])
                if img is None:
                    out[k] = None, None, why, None
                else:
                    # a large photo's search takes a few hundred MB (the sector detector on
                    # its reduced copy): one at a time, the others decoded meanwhile
                    with one_large if img.size > LARGE_PIXELS else contextlib.nullcontext():
                        found = find_chessboard_corners(img, cols, rows)
                    # judged while the photo is in memory: only its corners are kept
                    seems = None if found is None else seeming_size(img, found, cols, rows)
                    out[k] = img.shape[::-1], found, "", seems
                advance()  # a photo a step of the command's progress
        except Exception as e:  # raised in the caller, as without threads (Ctrl-C is at once)
            failed.append(e)

    # OpenCV's decoders print their own warnings (a float TIFF: a dozen lines); a photo's fate
    # is said once, in the rejected list. Set once: the level is the process's, not a thread's
    level = cv2.utils.logging.getLogLevel()
    cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_ERROR)
    n = max(min(os.cpu_count() or 1, len(paths), 4), 1)
    # daemons: an interrupted command exits without waiting for their photos
    threads = [threading.Thread(target=detect, args=(n, i), daemon=True) for i in range(1, n)]
    try:
        for t in threads:
            t.start()
        detect(n, 0)
        for t in threads:
            t.join()
    finally:
        cv2.utils.logging.setLogLevel(level)
    if failed:
        raise failed[0]
    return out


def _labels(paths: list[Path]) -> dict[Path, str]:
    """Each photo's name in intrinsics.json: its file name, or its path where two share a name."""
    counts: dict[str, int] = {}
    for p in paths:
        counts[p.name] = counts.get(p.name, 0) + 1
    return {p: p.name if counts[p.name] == 1 else str(p) for p in paths}


# OpenCV's order of the distortion coefficients (radial k1 k2, tangential p1 p2, radial k3)
DIST_NAMES = ("k1", "k2", "p1", "p2", "k3")
# what to change when the solve wanders: the views, or the model they cannot determine
_NOT_CONVERGED = (
    ": the views do not pin the model down; tilt the board 20-45 degrees in different "
    "directions, bring it into the image's corners, or fit less (--radial 2, --no-tangential, "
    "--fix-aspect)"
)
# the usual slip when no photo shows the board: its squares counted instead of its inner corners
_COUNT_INNER = (
    "; --cols and --rows count inner corners, where four squares meet: a board of "
    "{cols} x {rows} squares has --cols {c} --rows {r}"
)
MAX_PIXELS = MAX_IMAGE_PIXELS
# px: a photo over this is searched for its board one at a time (the sector detector's copy of
# 1024 px took 200 MB where no board was found: a few at once would pass the 600 MB a command
# may take)
LARGE_PIXELS = 4_000_000
# px: OpenCV's chessboard detector asserts on an image of 14 px or less a side (its adaptive
# threshold's block); no board's corners are found in so few pixels anyway
MIN_SIDE = 16
# bytes: the file is held while it is decoded, beside the decoder's own buffer (an uncompressed
# 16-bit TIFF: as large again); a 32-megapixel photo is 96 MB as an uncompressed 8-bit TIFF
MAX_FILE_BYTES = 100_000_000
# the formats a calibration photo comes in, by their first bytes; OpenCV's other decoders
# (JPEG 2000, AVIF, Radiance HDR, PFM, GIF) took 10-20 bytes a pixel, and no bound on pixels
# keeps those under the bound on memory
PHOTO_SIGNATURES = (
    b"\xff\xd8\xff",  # JPEG
    b"\x89PNG\r\n\x1a\n",
    b"II*\x00",  # TIFF, little- and big-endian, and BigTIFF
    b"MM\x00*",
    b"II+\x00",
    b"MM\x00+",
    b"BM",  # BMP
    b"P1",  # PBM, PGM, PPM, plain and binary, and PAM
    b"P2",
    b"P3",
    b"P4",
    b"P5",
    b"P6",
    b"P7",
)
_UNREADABLE = (
    "not a readable image (truncated, not an image, or not a JPEG, PNG, TIFF, BMP, PGM/PPM or "
    "WebP file)"
)


_DECODING = threading.Lock()


@contextlib.contextmanager
def _libpng_said_nowhere() -> Iterator[None]:
    """The process's stderr (file descriptor 2) caught while a PNG decodes: libpng writes its
    warnings there itself ("libpng warning: tEXt: CRC error"), where they would come before the
    command's one line; anything else written meanwhile (another thread's progress) is written
    back after. One decode at a time; where no temporary file can be made, nothing is caught."""
    with _DECODING:
        try:
            tmp = tempfile.TemporaryFile()
        except OSError:
            yield
            return
        with tmp:
            sys.stderr.flush()
            saved = os.dup(2)
            os.dup2(tmp.fileno(), 2)
            try:
                yield
            finally:
                sys.stderr.flush()
                os.dup2(saved, 2)
                os.close(saved)
                tmp.seek(0)
                kept = [ln for ln in tmp.read().splitlines(True) if not ln.startswith(b"libpng")]
                if kept:
                    os.write(2, b"".join(kept))


def _read_gray(path: Path) -> tuple[np.ndarray | None, str]:
    """The photo in grey levels, or None and why. Decoded from its bytes: imdecode refuses a
    truncated JPEG, where imread would return its grey remainder and print libjpeg's warning.

    A photo over :data:`MAX_PIXELS`, in any format, is refused by OpenCV itself between reading
    its header and allocating its pixels (``OPENCV_IO_MAX_IMAGE_PIXELS``, set by
    :mod:`calibench` before cv2 loads); a file over :data:`MAX_FILE_BYTES`, or in a format other
    than :data:`PHOTO_SIGNATURES` (and WebP), before it is decoded.
    """
    try:
        if path.stat().st_size > MAX_FILE_BYTES:
            return None, (
                f"a file over {MAX_FILE_BYTES / 1e6:.0f} MB: not a calibration photo (save it "
                "as PNG or JPEG)"
            )
        raw = path.read_bytes()
    except OSError as e:
        return None, f"cannot read it ({e.strerror})"
    webp = raw[:4] == b"RIFF" and raw[8:12] == b"WEBP"
    if not (webp or raw.startswith(PHOTO_SIGNATURES)):
        return None, _UNREADABLE
    why = tiff_tiles_beyond_the_image(raw)
    if why:
        return None, why
    decoding_is_bounded()
    try:
        with _libpng_said_nowhere() if raw.startswith(b"\x89PNG") else contextlib.nullcontext():
            img = cv2.imdecode(np.frombuffer(raw, np.uint8), cv2.IMREAD_GRAYSCALE)
    except cv2.error as e:
        if _OVER_LIMIT in str(e):
            return None, (
                f"more than {MAX_PIXELS / 1e6:.0f} megapixels, over the limit of what is decoded "
                "(a calibration needs no more: scale the photos down)"
            )
        img = None  # a decoder's own assertion on a malformed file
    if img is None:
        return None, _UNREADABLE
    if min(img.shape) < MIN_SIDE:
        return None, (
            f"{img.shape[1]} x {img.shape[0]} pixels: too small to show a chessboard (at least "
            f"{MIN_SIDE} px a side)"
        )
    return img, ""


def tiff_tiles_beyond_the_image(raw: bytes) -> str:
    """Why a TIFF is refused, or "": tiles larger than its image (padded to 1024 px).

    OpenCV's TIFF decoder allocates a whole tile as the file declares it, before the pixel
    bound can say anything: a 16 x 16 TIFF of 900 bytes declaring 11520 x 11520 tiles took
    550 MB. The tags are read by Pillow, without decoding.
    """
    if raw[:4] not in (b"II*\x00", b"MM\x00*", b"II+\x00", b"MM\x00+"):
        return ""
    import io

    from PIL import Image

    try:
        with Image.open(io.BytesIO(raw)) as im:
            w, h = im.size
            tags = getattr(im, "tag_v2", {})
            tile = int(tags.get(322, 0)), int(tags.get(323, 0))
    except Exception:  # noqa: BLE001 - a file Pillow cannot read is OpenCV's to judge
        return ""
    if tile[0] > max(w, 1024) + 15 or tile[1] > max(h, 1024) + 15:
        return (
            f"a TIFF of {w} x {h} pixels declaring tiles of {tile[0]} x {tile[1]}: not a "
            "calibration photo (save it as PNG or JPEG)"
        )
    return ""


# what OpenCV's refusal of an image over OPENCV_IO_MAX_IMAGE_PIXELS says
_OVER_LIMIT = "CV_IO_MAX_IMAGE_PIXELS"
_BOUNDED: list[bool] = []


def decoding_is_bounded() -> None:
    """RuntimeError unless OpenCV refuses to decode more than :data:`MAX_PIXELS` pixels.

    OpenCV reads its limit once, when cv2 loads: a program that imported cv2 before calibench
    decodes up to a gigapixel. Asked once per process, by decoding a header just over the limit
    with no pixels behind it (refused before anything is allocated where the limit holds).
    """
    if not _BOUNDED:
        side = int(MAX_PIXELS**0.5) + 1
        probe = np.frombuffer(f"P5\n{side} {side}\n255\n".encode(), np.uint8)
        try:
            cv2.imdecode(probe, cv2.IMREAD_GRAYSCALE)
            _BOUNDED.append(False)
        except cv2.error as e:
            _BOUNDED.append(_OVER_LIMIT in str(e))
    if not _BOUNDED[0]:
        raise RuntimeError(
            "OpenCV was loaded before calibench set its decoding limit "
            "(OPENCV_IO_MAX_IMAGE_PIXELS): import calibench before cv2"
        )


def run_camera(
    paths: list[Path],
    cols: int,
    rows: int,
    square_mm: float,
    fix_aspect: bool,
    radial: int,
    tangential: bool,
    out_dir: Path,
) -> dict:
    """The ``camera`` command: calibrate from photos of a chessboard and write ``intrinsics.json``.

    paths : the photos; cols, rows : inner corners per row and per column; square_mm : a
    square's side (mm). Returns intrinsics.json's content: K (3, 3) px, dist (k1, k2, p1, p2,
    k3), each parameter's std, the RMS reprojection error (px), the photos used and rejected
    (with why); camera.png beside it (:func:`write_camera_figure`). Raises BadInput when fewer
    than 3 distinct views of the board remain.
    """
    corners: dict = {}
    fonts = warm_fonts()
    result = calibrate_photos(
        paths, cols, rows, square_mm, fix_aspect, radial, tangential, corners_out=corners
    )
    result["corner_coverage"] = coverage(corners, tuple(result["image_size"]))
    out_dir.mkdir(parents=True, exist_ok=True)
    write_text(out_dir / "intrinsics.json", json.dumps(result, indent=2) + "\n")
    fonts.join()
    write_camera_figure(out_dir / "camera.png", result, corners)
    return result


def _not_a_file(p: Path) -> str:
    """Why ``p`` is not an image file, in words: a folder, a symbolic link loop, or nothing."""
    if p.is_dir():
        return "a folder, not an image (give the photos themselves: DIR/*.jpg)"
    if p.is_symlink():
        try:
            p.resolve(strict=True)
        except (RuntimeError, OSError):
            return "a symbolic link that leads nowhere (a loop, or a missing target)"
    return "no such image"
