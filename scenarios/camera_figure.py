"""camera.png: how well each photo fits the calibration, and where in the image the corners lie
(a calibration knows the lens only where the board went: corners missing from the image's edges
leave its distortion there a guess)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from calibench.scenarios import cvplot

COVERAGE_GRID = 8  # the image cut into 8 x 8 cells for the coverage figure
# below this share of the cells the console says to add photos near the edges (the usual advice:
# the board should reach every part of the image across the photos)
COVERAGE_WARN = 0.5


def coverage(corners: dict, size: tuple[int, int]) -> float:
    """Share of the image's COVERAGE_GRID x COVERAGE_GRID cells that hold at least one corner.

    Parameters
    ----------
    corners : dict of str to ndarray
        Each photo's corners, (n_corners, 2) px (NaN where left out).
    size : (width, height) px
    """
    pts = np.concatenate([np.asarray(c) for c in corners.values()]) if corners else np.zeros((0, 2))
    pts = pts[np.isfinite(pts).all(axis=1)]
    cells = np.floor(pts / np.asarray(size, float) * COVERAGE_GRID).astype(int)
    cells = cells[((cells >= 0) & (cells < COVERAGE_GRID)).all(axis=1)]
    return len({tuple(c) for c in cells}) / COVERAGE_GRID**2


WIDTH, HEIGHT = 1100, 460  # camera.png, px


def _bars(img, box, per_view: dict, rms_px: float) -> None:
    """Each photo's RMS as a bar, the whole calibration's as a dashed line, in ``box``
    (x0, y0, x1, y1) px."""
    import cv2

    x0, y0, x1, y1 = box
    names = list(per_view)
    top = 1.15 * max([rms_px, *per_view.values()]) or 1.0
    tick = cvplot.tick(top)

    def y(v):
        return int(y1 - (y1 - y0) * v / top)

    cv2.rectangle(img, (x0, y0), (x1, y1), cvplot.INK, 1)
    for v in np.arange(0.0, top, tick):
        cv2.line(img, (x0 - 4, y(v)), (x0, y(v)), cvplot.INK, 1)
        cvplot.text(img, f"{v:.3g}", (x0 - 7, y(v) + 4), 0.38, anchor="right")
    step = (x1 - x0) / max(len(names), 1)
    for k, name in enumerate(names):
        left = int(x0 + (k + 0.15) * step)
        right = max(int(x0 + (k + 0.85) * step), left + 1)
        cv2.rectangle(img, (left, y(per_view[name])), (right, y1), (180, 119, 31), -1)
        cvplot.vertical_text(img, name[-14:], (int(x0 + (k + 0.5) * step), y1 + 80))
    for xa in range(x0, x1, 12):  # the dashed line of the whole calibration
        cv2.line(img, (xa, y(rms_px)), (min(xa + 6, x1), y(rms_px)), cvplot.INK, 1)
    cvplot.text(img, f"all photos {rms_px:.3f} px", (x1 - 6, y(rms_px) - 6), 0.42, anchor="right")
    cvplot.text(
        img,
        "each photo's fit: RMS reprojection error (px)",
        ((x0 + x1) // 2, y0 - 10),
        0.5,
        anchor="centre",
    )


def _corners(img, box, corners: dict, size: tuple[int, int]) -> None:
    """Every corner used, coloured by photo, inside the image's outline, with the coverage
    grid, in ``box`` (x0, y0, x1, y1) px."""
    import cv2

    x0, y0, x1, y1 = box
    w, h = size
    scale = min((x1 - x0) / w, (y1 - y0) / h)
    ox, oy = x0 + ((x1 - x0) - scale * w) / 2, y0 + ((y1 - y0) - scale * h) / 2
    for k in range(1, COVERAGE_GRID):
        gx, gy = int(ox + scale * w * k / COVERAGE_GRID), int(oy + scale * h * k / COVERAGE_GRID)
        cv2.line(img, (gx, int(oy)), (gx, int(oy + scale * h)), cvplot.GREY, 1)
        cv2.line(img, (int(ox), gy), (int(ox + scale * w), gy), cvplot.GREY, 1)
    cv2.rectangle(
        img, (int(ox), int(oy)), (int(ox + scale * w), int(oy + scale * h)), cvplot.INK, 1
    )
    n = max(len(corners) - 1, 1)
    ramp = np.arange(256, dtype=np.uint8).reshape(-1, 1)
    palette = cv2.applyColorMap(ramp, cv2.COLORMAP_VIRIDIS)[:, 0]
    for k, c in enumerate(corners.values()):
        c = np.asarray(c, float)
        c = c[np.isfinite(c).all(axis=1)]
        color = tuple(int(v) for v in palette[int(round(255 * k / n))])
        for u, v in np.round(np.c_[ox + scale * c[:, 0], oy + scale * c[:, 1]]).astype(int):
            cv2.circle(img, (int(u), int(v)), 2, color, -1, cv2.LINE_AA)
    share = coverage(corners, size)
    cvplot.text(
        img,
        f"where the corners lie: {share:.0%} of the image's {COVERAGE_GRID} x "
        f"{COVERAGE_GRID} cells (grey)",
        ((x0 + x1) // 2, y0 - 10),
        0.5,
        anchor="centre",
    )
    cvplot.text(
        img, f"u 0-{w} px, v 0-{h} px (v down)", ((x0 + x1) // 2, y1 + 22), 0.42, anchor="centre"
    )


def write_camera_figure(path: Path, result: dict, corners: dict) -> None:
    """Left: the RMS reprojection error of each photo used, with the whole calibration's; right:
    every corner used, in the image's pixels, coloured by photo, and the coverage. Drawn with
    OpenCV, which the command has loaded anyway: a plotting library's import would double the
    whole command's time (issue 39)."""

    img = np.full((HEIGHT, WIDTH, 3), 255, np.uint8)
    w, h = result["image_size"]
    cvplot.text(
        img,
        f"{len(result['per_view_rms_px'])} photos, {w} x {h}: fx {result['K'][0][0]:.1f}, fy "
        f"{result['K'][1][1]:.1f} px; "
        + ", ".join(f"{k} {v:+.4g}" for k, v in result["distortion"].items()),
        (WIDTH // 2, 24),
        0.5,
        anchor="centre",
    )
    _bars(img, (70, 70, 520, 350), result["per_view_rms_px"], result["rms_px"])
    _corners(img, (580, 70, 1080, 420), corners, (w, h))
    cvplot.write_png(path, img)
