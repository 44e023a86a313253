"""Sub-pixel centres of dark circles on a bright plate, and the perspective bias of circle centres.

Pixels in OpenCV's convention (centre of the top-left pixel at (0, 0)). The extraction is the
classic one made sub-pixel: threshold (Otsu) and contour to find the blob, then edge points along
radial rays at the mid grey level (linear interpolation of a smoothed profile), then a
least-squares conic through them. The conic's centre is the ellipse centre; under perspective it
is not the image of the circle's centre, and :func:`ellipse_centre_bias` gives the difference
exactly from the image conic of the circle.
"""

from __future__ import annotations

import dataclasses

import cv2
import numpy as np
from scipy import ndimage

SEARCH_MARGIN_PX = 5.0  # beyond the blob's contour, each way: where a ray's crossing is sought


@dataclasses.dataclass(frozen=True)
class CircleFit:
    """centre (2,) px; radius_px (mean of the ellipse's semi-axes); rms_px of the edge points
    about the conic (geometric, approximate); n_edge points used."""

    centre: np.ndarray
    radius_px: float
    rms_px: float
    n_edge: int


def find_dark_circle(
    gray: np.ndarray,
    near: np.ndarray | None = None,
    min_radius_px: float = 10.0,
    n_rays: int = 720,
    smooth_px: float = 1.0,
) -> CircleFit | None:
    """The dark, whole (not cut by the border) circle whose centre is nearest ``near``.

    ``near`` defaults to the image centre. Returns None when no such circle is in the image.
    """
    img = np.asarray(gray)
    if img.ndim == 3:
        img = cv2.cvtColor(img, cv2.COLOR_RGB2GRAY)
    h, w = img.shape
    near = np.array([(w - 1) / 2, (h - 1) / 2]) if near is None else np.asarray(near, float)
    blur = cv2.GaussianBlur(img, (0, 0), 1.5)
    level, mask = cv2.threshold(blur, 0, 255, cv2.THRESH_BINARY_INV + cv2.THRESH_OTSU)
    contours, _ = cv2.findContours(mask, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    best, best_d = None, np.inf
    for c in contours:
        pts = c.reshape(-1, 2)
        if len(pts) < 20:
            continue
        if (
            pts[:, 0].min() <= 1
            or pts[:, 1].min() <= 1
            or pts[:, 0].max() >= w - 2
            or pts[:, 1].max() >= h - 2
        ):
            continue  # cut by the border: its centre would be biased
        (cx, cy), r = cv2.minEnclosingCircle(c)
        area = cv2.contourArea(c)
        if r < min_radius_px or area < 0.8 * np.pi * r * r:
            continue  # too small, or not round
        d = np.hypot(cx - near[0], cy - near[1])
        if d < best_d:
            best, best_d = (np.array([cx, cy]), r, pts), d
    if best is None:
        return None
    dark, bright = medians_in_and_out(img, mask)
    if bright - dark < 20:
        return None
    # the profiles reach radius + half-width; the filter's kernel 4 sigma beyond, and the sampling
    # a pixel: the block around them filters to the same values as the whole image
    reach = best[1] + max(6.0, 0.15 * best[1]) + 4 * smooth_px + 3
    lo = np.maximum(np.floor(best[0] - reach).astype(int), 0)
    hi = np.minimum(np.ceil(best[0] + reach).astype(int) + 1, [w, h])
    block = img[lo[1] : hi[1], lo[0] : hi[0]].astype(np.float32)
    # scipy's gaussian_filter (truncate 4, mirrored edges) as OpenCV's, 8x faster: within 1e-4
    # grey levels of it in float32, and the rays never read the edges the two treat alike
    taps = 2 * int(4 * smooth_px + 0.5) + 1
    smooth = cv2.GaussianBlur(block, (taps, taps), smooth_px, borderType=cv2.BORDER_REFLECT)
    # the contour of the blob bounds where the edge can be: the rays search between its nearest
    # and farthest points, a margin each way (the same points as a search of the whole width)
    dist = np.hypot(*(best[2] - best[0]).T)
    edge = radial_edge_points(
        smooth,
        best[0] - lo,
        best[1],
        (dark + bright) / 2,
        n_rays,
        within=(dist.min() - SEARCH_MARGIN_PX, dist.max() + SEARCH_MARGIN_PX),
    )
    edge = edge + lo
    if len(edge) < 0.8 * n_rays:
        return None
    centre, axes, rms = fit_conic_centre(edge)
    return CircleFit(centre=centre, radius_px=float(np.mean(axes)), rms_px=rms, n_edge=len(edge))


def medians_in_and_out(img: np.ndarray, mask: np.ndarray) -> tuple[float, float]:
    """The medians of ``img`` where the uint8 ``mask`` is set and where it is not, from the
    histograms of a uint8 image (OpenCV's: a fifth of numpy's indexing)."""
    if img.dtype != np.uint8:
        return float(np.median(img[mask > 0])), float(np.median(img[mask == 0]))
    inside = cv2.calcHist([img], [0], mask, [256], [0, 256]).ravel().astype(np.int64)
    every = cv2.calcHist([img], [0], None, [256], [0, 256]).ravel().astype(np.int64)
    return _histogram_median(inside), _histogram_median(every - inside)


def _histogram_median(counts: np.ndarray) -> float:
    """``np.median`` of the values whose (256,) histogram is ``counts``."""
    cumulative = np.cumsum(counts)
    n = int(cumulative[-1])
    lower = int(np.searchsorted(cumulative, (n - 1) // 2, side="right"))
    upper = int(np.searchsorted(cumulative, n // 2, side="right"))
    return (lower + upper) / 2


def radial_edge_points(
    image: np.ndarray,
    centre: np.ndarray,
    radius: float,
    level: float,
    n_rays: int,
    half_width: float | None = None,
    step: float = 0.25,
    within: tuple[float, float] | None = None,
) -> np.ndarray:
    """Where each radial ray crosses ``level`` near ``radius``, shape (n_found, 2) px.

    Profiles are sampled bilinearly every ``step`` px over +-``half_width`` around the radius;
    the crossing is the first from below the level to at or above it going outwards, linearly
    interpolated between the two samples that bracket it.

    ``within`` (inner, outer) px: where the caller expects the crossings. The samples inside
    ``inner`` are skipped when no pixel they read reaches the level (none of them can then hold
    the first crossing), and the rays are sampled out to ``outer`` first; a ray without its
    crossing there is sampled over the whole width. The points are those of the whole width's
    search, at a fraction of its samples.
    """
    hw = half_width if half_width is not None else max(6.0, 0.15 * radius)
    ang = np.linspace(0, 2 * np.pi, n_rays, endpoint=False)
    d = np.stack([np.cos(ang), np.sin(ang)], axis=1)  # (n_rays, 2)
    rr = np.arange(radius - hw, radius + hw + step / 2, step)  # (n_samples,)
    k_lo, k_hi = 0, len(rr) - 1
    if within is not None:
        k_lo = int(np.clip(np.floor((within[0] - rr[0]) / step), 0, len(rr) - 1))
        k_hi = int(np.clip(np.ceil((within[1] - rr[0]) / step), k_lo + 1, len(rr) - 1))
        if k_lo > 0 and not _below_within(image, centre, rr[k_lo], level):
            k_lo = 0
    k, r_edge = _first_crossings(image, centre, d, rr[k_lo : k_hi + 1], level, step)
    if k_lo > 0 or k_hi < len(rr) - 1:
        again = np.flatnonzero(k < 0)
        if len(again):  # no crossing where expected: the whole width, as without ``within``
            k[again], r_edge[again] = _first_crossings(image, centre, d[again], rr, level, step)
    rows = np.flatnonzero(k >= 0)
    return centre + d[rows] * r_edge[rows, None]


def _first_crossings(
    image: np.ndarray, centre: np.ndarray, d: np.ndarray, rr: np.ndarray, level: float, step: float
) -> tuple[np.ndarray, np.ndarray]:
    """Each ray's (``d`` (n_rays, 2)) first upward crossing of ``level`` among its samples at
    radii ``rr`` (n_samples,): the sample before it (-1 where none) and its radius (n_rays,)."""
    rows = centre[1] + d[:, 1:] * rr  # (n_rays, n_samples)
    cols = centre[0] + d[:, :1] * rr
    prof = ndimage.map_coordinates(
        image, [rows.ravel(), cols.ravel()], order=1, mode="nearest"
    ).reshape(rows.shape)
    above = prof >= level
    trans = (~above[:, :-1]) & above[:, 1:]
    ok = trans.any(axis=1)
    k = np.argmax(trans, axis=1)
    at = np.arange(len(k))
    p0, p1 = prof[at, k], prof[at, k + 1]
    with np.errstate(divide="ignore", invalid="ignore"):
        r_edge = rr[k] + (level - p0) / (p1 - p0) * step
    return np.where(ok, k, -1), r_edge


def _below_within(image: np.ndarray, centre: np.ndarray, radius: float, level: float) -> bool:
    """Whether every pixel of ``image`` that a bilinear sample within ``radius`` of ``centre``
    reads (its four neighbours: within radius + sqrt 2) is below ``level``."""
    disc = np.zeros(image.shape, np.uint8)
    reach = int(np.ceil(radius + np.sqrt(2) + 1))  # and the centre's rounding
    cv2.circle(disc, (int(round(centre[0])), int(round(centre[1]))), reach, 255, -1)
    return bool(cv2.minMaxLoc(image, disc)[1] < level)


def fit_conic_centre(points: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """Least-squares ellipse through points (n, 2): centre (2,), semi-axes (2,), rms residual.

    The conic a x^2 + b xy + c y^2 + d x + e y = 1 is fitted on coordinates centred and scaled
    for conditioning; the residual is the algebraic one scaled to pixels at the mean radius.
    """
    m = points.mean(axis=0)
    s = np.sqrt(np.mean(np.sum((points - m) ** 2, axis=1)))
    x, y = ((points - m) / s).T
    A = np.stack([x * x, x * y, y * y, x, y], axis=1)
    coef, *_ = np.linalg.lstsq(A, np.ones_like(x), rcond=None)
    a, b, c, d, e = coef
    M = np.array([[2 * a, b], [b, 2 * c]])
    centre_n = np.linalg.solve(M, [-d, -e])
    # semi-axes from the conic in centred form
    k = 1 - (
        a * centre_n[0] ** 2
        + b * centre_n[0] * centre_n[1]
        + c * centre_n[1] ** 2
        + d * centre_n[0]
        + e * centre_n[1]
    )
    ev = np.linalg.eigvalsh(np.array([[a, b / 2], [b / 2, c]]))
    axes = np.sqrt(k / ev) * s
    resid = A @ coef - 1
    rms = float(np.sqrt(np.mean(resid**2)) * s / 2)  # algebraic -> ~geometric for a circle
    return m + s * centre_n, axes, rms


def ellipse_centre_bias(
    K: np.ndarray, R_plane2cam: np.ndarray, t_centre_cam: np.ndarray, radius: float
) -> np.ndarray:
    """Image of a circle's ellipse centre minus the image of its centre, (2,) px.

    The circle lies in the plane z = 0 of a frame whose origin is the circle's centre, placed by
    ``R_plane2cam`` (3, 3) and ``t_centre_cam`` (3,) (same length unit as ``radius``). Its image
    is the conic C' = H^-T diag(1, 1, -r^2) H^-1 with H = K [r1 r2 t]; the ellipse centre is
    C'^-1 (0, 0, 1) dehomogenised. Zero for a fronto-parallel view; grows as r^2 tilt / Z.
    """
    H = K @ np.column_stack([R_plane2cam[:, 0], R_plane2cam[:, 1], t_centre_cam])
    Hi = np.linalg.inv(H)
    C = Hi.T @ np.diag([1.0, 1.0, -radius * radius]) @ Hi
    c = np.linalg.solve(C, [0.0, 0.0, 1.0])
    p = H[:, 2]
    return c[:2] / c[2] - p[:2] / p[2]
