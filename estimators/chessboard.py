"""Chessboard inner-corner detection with sub-pixel accuracy.

Pixels in OpenCV's convention (centre of the top-left pixel at (0, 0)). Corners come back in
the board's order (row-major, ``cols`` per row, see ``scenes.checkerboard`` for the frame):
when ``cols + rows`` is odd the order is made unambiguous by the colour of the square before
corner 0 (black); a symmetric board keeps the detector's order, which is still a valid pose.
"""

from __future__ import annotations

import cv2
import numpy as np

# The sector-based detector refines corners itself (about 0.07 px on 17 px squares here);
# histogram normalisation doubles that error, so it is not used.
_SB_FLAGS = cv2.CALIB_CB_ACCURACY | cv2.CALIB_CB_EXHAUSTIVE
_CLASSIC_FLAGS = cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE
_SUBPIX = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 100, 1e-4)


def to_gray(image: np.ndarray) -> np.ndarray:
    """uint8 grey image, shape (h, w), from grey or RGB (h, w, 3)."""
    if image.ndim == 3:
        return cv2.cvtColor(image, cv2.COLOR_RGB2GRAY)
    return image


def find_chessboard_corners(image: np.ndarray, cols: int, rows: int) -> np.ndarray | None:
    """Inner corners of a ``cols`` x ``rows`` chessboard, shape (cols * rows, 2), or None.

    Tries OpenCV's sector-based detector first, then the classic detector followed by
    ``cornerSubPix`` (window scaled to the square size) for photos the first one misses.
    """
    gray = to_gray(image)
    ok, corners = cv2.findChessboardCornersSB(gray, (cols, rows), flags=_SB_FLAGS)
    if ok:
        corners = corners.reshape(-1, 2).astype(np.float64)
    else:
        ok, corners = cv2.findChessboardCorners(gray, (cols, rows), flags=_CLASSIC_FLAGS)
        if not ok:
            return None
        corners = corners.reshape(-1, 2)
        win = _subpix_window(corners, cols)
        corners = cv2.cornerSubPix(gray, corners.reshape(-1, 1, 2).astype(np.float32),
                                   (win, win), (-1, -1), _SUBPIX).reshape(-1, 2).astype(np.float64)
    return canonical_order(gray, corners, cols, rows)


def _subpix_window(corners: np.ndarray, cols: int) -> int:
    step = np.median(np.linalg.norm(np.diff(corners.reshape(-1, cols, 2), axis=1), axis=2))
    return int(np.clip(step * 0.4, 3, 11))


def canonical_order(gray: np.ndarray, corners: np.ndarray, cols: int, rows: int) -> np.ndarray:
    """Reverse the order if the square before corner 0 is white (boards with cols + rows odd)."""
    if (cols + rows) % 2 == 0:
        return corners
    grid = corners.reshape(rows, cols, 2)
    # the square before corner 0 lies opposite corner (1, 1) across corner 0
    probe0 = grid[0, 0] - 0.5 * (grid[1, 1] - grid[0, 0])
    probe1 = grid[-1, -1] - 0.5 * (grid[-2, -2] - grid[-1, -1])
    if _sample(gray, probe0) > _sample(gray, probe1):
        return corners[::-1].copy()
    return corners


def _sample(gray: np.ndarray, uv: np.ndarray) -> float:
    u, v = np.clip(np.rint(uv).astype(int), 0, [gray.shape[1] - 1, gray.shape[0] - 1])
    return float(gray[max(v - 1, 0):v + 2, max(u - 1, 0):u + 2].mean())
