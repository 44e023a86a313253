"""Chessboard inner-corner detection with sub-pixel accuracy.

Detection is OpenCV's (classic, else sector-based); the sub-pixel position is then the saddle
point of the smoothed image, found by a weighted quadratic fit iterated to convergence. Two
straight edges crossing make a pattern that is point-symmetric about the crossing under any
perspective, so a symmetric window centred on it has no bias: on tilted, lens-distorted renders
this takes corners from 0.05-0.3 px RMS (OpenCV's own refinement) to 0.01-0.05 px.

Pixels in OpenCV's convention (centre of the top-left pixel at (0, 0)). Corners come back in
the board's order (row-major, ``cols`` per row, see ``scenes.checkerboard`` for the frame):
when ``cols + rows`` is odd the order is made unambiguous by the colour of the square before
corner 0 (black); a symmetric board keeps the detector's order, which is still a valid pose.
"""

from __future__ import annotations

import cv2
import numpy as np

from calibench.estimators.quantiles import nanmedian, percentile

# Histogram normalisation doubles the sector detector's error on renders: not used.
_SB_FLAGS = cv2.CALIB_CB_ACCURACY | cv2.CALIB_CB_EXHAUSTIVE
# no CALIB_CB_FAST_CHECK: with OpenCV 5.0 it makes a board's detection 3-4x slower (13 photos:
# 220 ms against 55 ms), and a photo without a board goes on to the sector detector anyway
_CLASSIC_FLAGS = cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE
# px: the detectors look for the board on a copy whose longer side is at most this (their time
# and memory grow with the image: a 50-megapixel photo took 30 s and 3.5 GB, and the sector
# detector on a photo without a board 103 MB at 640 px, 199 MB at 1024, 364 MB at 1536, 648 MB
# at 2048, and a command may take 600 MB); a board's squares keep 15 px or more at 1024 unless
# it fills less than a fifth of the photo; the saddle refinement then works at full resolution,
# so the corners lose nothing
DETECT_MAX_SIDE = 1024


def to_gray(image: np.ndarray) -> np.ndarray:
    """uint8 grey image, shape (h, w), from grey or RGB (h, w, 3)."""
    if image.ndim == 3:
        return cv2.cvtColor(image, cv2.COLOR_RGB2GRAY)
    return image


def find_chessboard_corners(image: np.ndarray, cols: int, rows: int) -> np.ndarray | None:
    """Inner corners of a ``cols`` x ``rows`` chessboard, shape (cols * rows, 2), or None.

    Tries OpenCV's classic detector first, then the sector-based one for photos it misses;
    either way the corners are then refined to the image's saddle points.
    """
    gray = to_gray(image)
    small = gray
    if max(gray.shape) > DETECT_MAX_SIDE:
        f = DETECT_MAX_SIDE / max(gray.shape)
        small = cv2.resize(gray, None, fx=f, fy=f, interpolation=cv2.INTER_AREA)
    # the classic detector finds most boards in a few ms; the saddle refinement below makes its
    # rough corners as good as the sector detector's, which costs 20-30x more and is kept for
    # the photos the classic one misses
    ok, corners = cv2.findChessboardCorners(small, (cols, rows), flags=_CLASSIC_FLAGS)
    if not ok:
        ok, corners = cv2.findChessboardCornersSB(small, (cols, rows), flags=_SB_FLAGS)
        if not ok:
            return None
    corners = corners.reshape(-1, 2).astype(np.float64)
    if small is not gray:  # pixel centres: (u + 0.5) scales with the image
        scale = np.array([gray.shape[1] / small.shape[1], gray.shape[0] / small.shape[0]])
        corners = (corners + 0.5) * scale - 0.5
    corners = refine_saddle(gray, corners, saddle_half_window(corners, cols, rows))
    return canonical_order(gray, corners, cols, rows)


def saddle_half_window(corners: np.ndarray, cols: int, rows: int) -> int:
    """Half window (px) that stays inside the four squares around each corner."""
    grid = corners.reshape(rows, cols, 2)
    steps = np.r_[
        np.linalg.norm(np.diff(grid, axis=1), axis=2).ravel(),
        np.linalg.norm(np.diff(grid, axis=0), axis=2).ravel(),
    ]
    return int(np.clip(np.round(0.3 * percentile(steps, 10)), 2, 10))


def refine_saddle(
    gray: np.ndarray,
    corners: np.ndarray,
    half_window: int,
    iterations: int = 20,
    tol_px: float = 1e-4,
) -> np.ndarray:
    """Move corners to the saddle point of the smoothed image, (n, 2) -> (n, 2) px.

    Each iteration samples a (2r+1)^2 grid centred on the current estimate (bilinear), fits
    f = a dx^2 + b dx dy + c dy^2 + d dx + e dy + g with Gaussian weights (one precomputed
    pseudo-inverse for all corners) and steps to the fit's stationary point. A corner whose
    fit is not a saddle keeps its last position.
    """
    r = int(half_window)
    sigma = max(0.8, r / 3)
    c = np.array(corners, float)
    # blur only the board's box: with a margin of the window, the step bound and the kernel's
    # 4 sigma, every sample sees the same values as in the whole image blurred
    h, w_img = gray.shape[:2]
    m = r + 1 + iterations + int(np.ceil(4 * sigma)) + 2
    x0, y0 = max(int(np.floor(c[:, 0].min())) - m, 0), max(int(np.floor(c[:, 1].min())) - m, 0)
    x1, y1 = (
        min(int(np.ceil(c[:, 0].max())) + m + 1, w_img),
        min(int(np.ceil(c[:, 1].max())) + m + 1, h),
    )
    blurred = cv2.GaussianBlur(gray[y0:y1, x0:x1].astype(np.float32), (0, 0), sigma)
    img: np.ndarray = blurred.astype(np.float64)  # copyMakeBorder below: typed any dtype
    if x0 == 0 or y0 == 0 or x1 == w_img or y1 == h:
        # a board at the image's edge: the edge repeated, so that no window leaves the image
        pad = r + iterations + 2
        img = cv2.copyMakeBorder(img, pad, pad, pad, pad, cv2.BORDER_REPLICATE)
        x0, y0 = x0 - pad, y0 - pad
    c -= (x0, y0)
    o = np.arange(-r, r + 1, dtype=float)
    dy, dx = (a.ravel() for a in np.meshgrid(o, o, indexing="ij"))
    w = np.exp(-(dx**2 + dy**2) / (2 * (r / 1.5) ** 2))
    A = np.stack([dx * dx, dx * dy, dy * dy, dx, dy, np.ones_like(dx)], axis=1)
    P = np.linalg.pinv(A * w[:, None]) * w[None, :]  # (6, m): coefficients = P @ samples
    active = np.arange(len(c))
    flat, width = img.ravel(), img.shape[1]
    offsets = (dy * width + dx).astype(np.intp)  # the window's samples, as steps in the flat image
    for _ in range(iterations):
        a, b, cc, d, e, _ = P @ _window(flat, width, c[active], offsets).T
        det = 4 * a * cc - b * b
        saddle = det < 0
        step = np.zeros((len(active), 2))
        with np.errstate(divide="ignore", invalid="ignore"):
            step[:, 0] = np.where(saddle, (b * e - 2 * cc * d) / det, 0)
            step[:, 1] = np.where(saddle, (b * d - 2 * a * e) / det, 0)
        step = np.clip(step, -1, 1)
        c[active] += step
        active = active[np.abs(step).max(axis=1) >= tol_px]
        if len(active) == 0:
            break
    return c + (x0, y0)


def _window(flat: np.ndarray, width: int, centres: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """Bilinear samples (n, m) of the flattened image at each centre (n, 2) plus the integer
    window ``offsets`` (m,): the four neighbours' weights are the centre's own, shared by its
    whole window. The centres keep the window inside the image (refine_saddle's margin)."""
    x0, y0 = np.floor(centres[:, 0]), np.floor(centres[:, 1])
    fx, fy = (centres[:, 0] - x0)[:, None], (centres[:, 1] - y0)[:, None]
    i = (y0.astype(np.intp) * width + x0.astype(np.intp))[:, None] + offsets
    top = np.take(flat, i) * (1 - fx) + np.take(flat, i + 1) * fx
    bottom = np.take(flat, i + width) * (1 - fx) + np.take(flat, i + width + 1) * fx
    return top * (1 - fy) + bottom * fy


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
    return float(gray[max(v - 1, 0) : v + 2, max(u - 1, 0) : u + 2].mean())


def grid_residuals(
    corners: np.ndarray, cols: int, rows: int, left_out: np.ndarray | None = None, half: int = 2
) -> np.ndarray:
    """Each corner against where its grid neighbours put it, (cols * rows,) px.

    A quadratic in grid steps (the board's perspective and the lens's distortion to second
    order) is fitted by least squares to each corner's neighbours within ``half`` steps (not the
    corner itself, nor the ``left_out`` mask's (n,) corners) and evaluated at the corner (at a
    board's corner that is an extrapolation from its 8 neighbours). NaN where fewer than 8 are
    left.
    """
    g = np.asarray(corners, float).reshape(rows, cols, 2)
    n = rows * cols
    out = np.zeros(n, bool) if left_out is None else np.asarray(left_out, bool)
    ii, jj = (a.ravel() for a in np.meshgrid(np.arange(rows), np.arange(cols), indexing="ij"))
    offs = np.array(
        [(a, b) for a in range(-half, half + 1) for b in range(-half, half + 1) if (a, b) != (0, 0)]
    )
    powers = [(p - q, q) for p in range(3) for q in range(p + 1)]
    M = np.stack([offs[:, 1] ** i * offs[:, 0] ** j for i, j in powers], axis=1).astype(
        float
    )  # (m, 6)
    ni, nj = ii[:, None] + offs[None, :, 0], jj[:, None] + offs[None, :, 1]
    inside = (ni >= 0) & (ni < rows) & (nj >= 0) & (nj < cols)
    ni, nj = np.clip(ni, 0, rows - 1), np.clip(nj, 0, cols - 1)
    w = (inside & ~out[ni * cols + nj]).astype(float)  # (n, m)
    P = g[ni, nj] - g.reshape(n, 1, 2)  # neighbours relative to the corner, (n, m, 2)
    A = np.einsum("nm,mk,ml->nkl", w, M, M) + 1e-9 * np.eye(len(powers))
    b = np.einsum("nm,mk,nmc->nkc", w, M, P)
    offset = np.linalg.solve(A, b)[:, 0]  # the constant term: the predicted corner, relative
    return np.where(w.sum(axis=1) >= 8, np.linalg.norm(offset, axis=1), np.nan)


def gross_corners(
    corners: np.ndarray, cols: int, rows: int, limit_px: float = 1.5
) -> list[tuple[int, float]]:
    """Corners that disagree with the board's grid: (index, residual px), in the order found.

    While some :func:`grid_residuals` exceed ``limit_px`` and 5 times the photo's median, the
    corner whose leaving out makes the others agree best (of the six worst; a gross corner pulls
    its neighbours' predictions, on a narrow board more than its own) is left out, and the rest
    looked at again. Correct corners of real photos sit under 0.7 px (the quadratic's own error
    on a strongly distorted lens); the detectors' gross errors are pixels.
    """
    n = rows * cols
    left = np.zeros(n, bool)
    found: list[tuple[int, float]] = []
    while len(found) < n // 4:
        r = grid_residuals(corners, cols, rows, left)
        r[left] = np.nan
        if np.all(np.isnan(r)) or np.nanmax(r) <= max(limit_px, 5 * nanmedian(r)):
            break
        worst = np.argsort(np.where(np.isnan(r), -np.inf, r))[::-1][:6]

        def others_after(k):
            trial = left.copy()
            trial[k] = True
            rest = grid_residuals(corners, cols, rows, trial)
            rest[trial] = np.nan
            return np.nanmax(rest) if np.any(~np.isnan(rest)) else 0.0

        k = int(min(worst, key=others_after))
        found.append((k, float(r[k])))
        left[k] = True
    return found
