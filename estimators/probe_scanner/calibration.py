"""Calibration of a rotary probe scanner (eyeglass-frame tracer) with a rounded-square opening.

Geometry (holder frame, mm, rad; the table turns about the origin O). At table angle theta the
rail points along u = (cos a, sin a), a = alpha0 + theta, and runs at distance d from O: its
points are X(s) = d n + s u with n = (-sin a, cos a). The stylus starts at Q = X(dL), inside the
opening, dL from the foot of the perpendicular; released, the spring pushes it outwards until it
stops on the opening's wall at P = X(dL + rho). The reading rho is the distance Q -> P, so a
calibrated (d, dL, alpha0) turns each sample (theta, rho) into a contour point P.

The calibration plate has a square opening of half-side ``a`` (45 mm: a = 22.5) with corners
rounded to radius ``r``, sides along the holder's axes, centre c (nominally O). On side k, with
outward normal psi_k and phi = alpha0 + theta - psi_k,

    rho(phi) = (a + d sin phi) / cos phi - dL,

whose minimum lies at sin phi* = -d / a with depth sqrt(a^2 - d^2) - dL and curvature
a^2 / sqrt(a^2 - d^2): the four minima of rho(theta) are the sides' feet.

Two methods:
- :func:`calibrate_paper`: quadratic fits over m samples around each minimum give its angle,
  depth and curvature, and the three unknowns follow in closed form (d from the curvature, dL
  from the depth, alpha0 from the angles). Few samples are noisy; many bend the quadratic away
  from the curve (the seed paper's sensitivity study over m).
- :func:`calibrate_lsq`: nonlinear least squares of (d, dL, alpha0, c) against the exact model
  of every sample, with standard deviations.
The square's fourfold symmetry leaves alpha0 defined modulo 90 degrees: both methods take the
mechanism's nominal alpha0 to pick the branch, and d > 0 by the mechanism's construction.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy import optimize

SIDE_NORMALS = np.deg2rad([0.0, 90.0, 180.0, 270.0])


@dataclasses.dataclass(frozen=True)
class ScannerCalibration:
    """d_mm, dL_mm, alpha0_rad and the plate centre (cx, cy) mm; std of each (None: no std) and
    their covariance (5, 5) in that order, mm and rad (None: none stated)."""

    d_mm: float
    dL_mm: float
    alpha0_rad: float
    centre_mm: np.ndarray
    std: dict | None = None
    rms_mm: float | None = None
    cov: np.ndarray | None = None


def contour_points(
    theta_rad: np.ndarray, rho_mm: np.ndarray, d_mm: float, dL_mm: float, alpha0_rad: float
) -> np.ndarray:
    """Contact points P in the holder frame from samples (n,), (n,) -> (n, 2) mm."""
    a = alpha0_rad + np.asarray(theta_rad, float)
    u = np.stack([np.cos(a), np.sin(a)], axis=1)
    n = np.stack([-np.sin(a), np.cos(a)], axis=1)
    return d_mm * n + (dL_mm + np.asarray(rho_mm, float))[:, None] * u


def rounded_square_rho(
    theta_rad: np.ndarray,
    d_mm: float,
    dL_mm: float,
    alpha0_rad: float,
    centre_mm,
    half_side_mm: float,
    corner_radius_mm: float,
) -> np.ndarray:
    """Exact reading rho (n,) in a rounded-square opening for samples at table angles theta (n,).

    The ray from Q along u leaves the opening where it leaves the square of half-side a, if that
    exit lies within +-b = a - r along the side; otherwise on the corner circle (radius r about
    (+-b, +-b)) of that quadrant. NaN where Q is not inside.
    """
    a = alpha0_rad + np.asarray(theta_rad, float)
    u = np.stack([np.cos(a), np.sin(a)], axis=1)
    n = np.stack([-np.sin(a), np.cos(a)], axis=1)
    q = d_mm * n + dL_mm * u - np.asarray(centre_mm, float)  # Q in the opening's frame
    A, b, r = half_side_mm, half_side_mm - corner_radius_mm, corner_radius_mm
    with np.errstate(divide="ignore", invalid="ignore"):
        t1 = (-A - q) / u
        t2 = (A - q) / u
    t_far = np.where(np.isfinite(t1), np.maximum(t1, t2), np.inf)
    t_exit = t_far.min(axis=1)
    axis = t_far.argmin(axis=1)
    e = q + t_exit[:, None] * u
    along = np.abs(e[np.arange(len(e)), 1 - axis])
    flat = along <= b
    w = q - np.sign(e) * b
    B = np.sum(w * u, axis=1)
    disc = B * B - (np.sum(w * w, axis=1) - r * r)
    t_corner = -B + np.sqrt(np.where(disc >= 0, disc, np.nan))
    rho = np.where(flat, t_exit, t_corner)
    return np.where(rho > 0, rho, np.nan)


# --- the paper's method --------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class MinimumFit:
    """A quadratic rho = c0 + c1 x + c2 x^2 fitted around one minimum (x = theta - theta_i)."""

    theta_rad: float  # the vertex
    rho_mm: float
    curvature_mm: float  # d^2 rho / d theta^2 at the vertex, mm / rad^2


def fit_minima(
    theta_rad: np.ndarray, rho_mm: np.ndarray, m: int, n_minima: int = 4
) -> list[MinimumFit]:
    """Quadratic fits over ``m`` consecutive samples centred on each of the ``n_minima`` lowest
    local minima of a full turn (the samples wrap around)."""
    th, rho = np.asarray(theta_rad, float), np.asarray(rho_mm, float)
    N = len(rho)
    if m < 3 or m > N // n_minima:
        raise ValueError(f"m = {m}: the quadratic needs 3 to {N // n_minima} samples")
    return _fits_at(th, rho, minima_indices(rho, n_minima), m)


def minima_indices(rho_mm: np.ndarray, n_minima: int = 4) -> np.ndarray:
    """The sample index of each of a turn's ``n_minima`` minima, (n_minima,): the lowest sample
    of each part of the turn between maxima, after light smoothing."""
    rho = np.asarray(rho_mm, float)
    N = len(rho)
    k = max(3, N // 200)
    smooth = np.convolve(np.r_[rho[-k:], rho, rho[:k]], np.ones(k) / k, mode="same")[k:-k]
    start = int(np.argmax(smooth))  # a maximum: quarters between maxima hold one minimum each
    out = []
    for q in range(n_minima):
        idx = (start + np.arange(q * N // n_minima, (q + 1) * N // n_minima)) % N
        out.append(idx[np.argmin(smooth[idx])])
    return np.array(out)


def _fits_at(th: np.ndarray, rho: np.ndarray, i0: np.ndarray, m: int) -> list[MinimumFit]:
    """The quadratic fits of ``m`` samples centred on the minima ``i0`` (k,), all at once."""
    N = len(rho)
    win = (i0[:, None] + np.arange(m) - (m - 1) // 2) % N  # (k, m)
    x = (th[win] - th[i0][:, None] + np.pi) % (2 * np.pi) - np.pi  # a window may wrap past 2 pi
    c2, c1, c0 = _quadratic(x, rho[win]).T
    vertex = c2 > 0  # else a window too short to see the curve through the quantisation
    with np.errstate(divide="ignore", invalid="ignore"):
        xv = np.where(vertex, -c1 / (2 * c2), 0.0)
        rv = np.where(vertex, c0 - c1 * c1 / (4 * c2), c0)
    fits = [
        MinimumFit(theta_rad=float(th[i] + v), rho_mm=float(r), curvature_mm=float(2 * c))
        for i, v, r, c in zip(i0, xv, rv, c2)
    ]
    return sorted(fits, key=lambda f: f.theta_rad % (2 * np.pi))


def _quadratic(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Least-squares (c2, c1, c0) of y = c2 x^2 + c1 x + c0 for each row of x, y (k, m) ->
    (k, 3): what np.polyfit gives row by row, without its overhead (thousands of small fits in a
    sweep over window sizes); x is scaled to [-1, 1] so the normal equations stay well
    conditioned."""
    s = np.maximum(np.abs(x).max(axis=1), 1e-300)[:, None]
    t = x / s
    V = np.stack([t * t, t, np.ones_like(t)], axis=2)  # (k, m, 3)
    Vt = V.swapaxes(-1, -2)
    c = np.linalg.solve(Vt @ V, Vt @ y[..., None])[..., 0]
    return c / np.c_[s * s, s, np.ones_like(s)]


def paper_sweep_d_mm(
    theta_rad: np.ndarray, rho_mm: np.ndarray, ms, half_side_mm: float
) -> np.ndarray:
    """The four-minima method's d (mm) for every window size in ``ms`` (M,) on one turn, (M,):
    :func:`calibrate_paper`'s d for each window size, all at once (the minima found once, each
    window padded to the largest, the padding weighted out of the quadratic's normal
    equations). d needs only the minima's mean curvature."""
    th, rho = np.asarray(theta_rad, float), np.asarray(rho_mm, float)
    N = len(rho)
    ms = np.asarray(ms, int)
    if ms.min() < 3 or ms.max() > N // 4:
        raise ValueError(
            f"m from {ms.min()} to {ms.max()}: the quadratic needs 3 to {N // 4} samples"
        )
    i0 = minima_indices(rho)
    k = np.arange(ms.max())
    inside = (k[None, :] < ms[:, None])[:, None, :].astype(float)  # (M, 1, m_max)
    win = (
        i0[None, :, None] + (k[None, :] - (ms[:, None] - 1) // 2)[:, None, :]
    ) % N  # (M, 4, m_max)
    x = (th[win] - th[i0][None, :, None] + np.pi) % (2 * np.pi) - np.pi
    scale = np.maximum(np.max(np.abs(x) * inside, axis=2), 1e-300)[
        ..., None
    ]  # as _quadratic: t in [-1, 1]
    t = x / scale
    V = np.stack([t * t, t, np.ones_like(t)], axis=3) * inside[..., None]  # (M, 4, m_max, 3)
    Vt = V.swapaxes(-1, -2)
    c = np.linalg.solve(Vt @ V, Vt @ rho[win][..., None])
    curvature = np.mean(2 * c[..., 0, 0] / scale[..., 0] ** 2, axis=1)  # (M,)
    a = half_side_mm
    with np.errstate(divide="ignore", invalid="ignore"):
        d = np.sqrt(np.maximum(a * a - (a * a / curvature) ** 2, 0.0))
    return np.where(curvature > a, d, 0.0)


def calibrate_paper(
    theta_rad: np.ndarray,
    rho_mm: np.ndarray,
    m: int,
    half_side_mm: float,
    alpha0_nominal_rad: float,
) -> ScannerCalibration:
    """The four-minima method, in closed form for a centred opening of half-side a:
    C = a^2 / sqrt(a^2 - d^2) gives d, the depth sqrt(a^2 - d^2) - dL gives dL, and the
    vertex angles alpha0 + theta_k = psi_k - asin(d / a) give alpha0 (averaged over the four)."""
    return solve_four_minima(fit_minima(theta_rad, rho_mm, m), half_side_mm, alpha0_nominal_rad)


def solve_four_minima(
    fits: list[MinimumFit], half_side_mm: float, alpha0_nominal_rad: float
) -> ScannerCalibration:
    """(d, dL, alpha0) from the four minima of a centred opening, in closed form."""
    a = half_side_mm
    curv = float(np.mean([f.curvature_mm for f in fits]))
    d = float(np.sqrt(max(a * a - (a * a / curv) ** 2, 0.0))) if curv > a else 0.0
    dL = float(np.sqrt(a * a - d * d) - np.mean([f.rho_mm for f in fits]))
    alpha0 = _alpha0_from_minima(
        np.array([f.theta_rad for f in fits]), -np.arcsin(d / a), alpha0_nominal_rad
    )
    return ScannerCalibration(d_mm=d, dL_mm=dL, alpha0_rad=alpha0, centre_mm=np.zeros(2))


def _alpha0_from_minima(theta_k: np.ndarray, phi: float, nominal: float) -> float:
    """alpha0 with alpha0 + theta_k = psi_k + phi: each minimum's estimate modulo 90 degrees,
    averaged, on the branch nearest the nominal alpha0."""
    est = phi - theta_k
    # fourfold: average 4 x angle on the circle, then divide
    mean4 = np.angle(np.mean(np.exp(4j * est))) / 4
    k = np.round((nominal - mean4) / (np.pi / 2))
    return float(np.angle(np.exp(1j * (mean4 + k * np.pi / 2))))


# --- the full-data method --------------------------------------------------------------------
def calibrate_lsq(
    theta_rad: np.ndarray,
    rho_mm: np.ndarray,
    half_side_mm: float,
    corner_radius_mm: float,
    start: ScannerCalibration,
) -> ScannerCalibration:
    """Least squares of (d, dL, alpha0, cx, cy) against every sample's exact reading.

    Standard deviations and covariance from (J^T J)^-1 scaled by the residual variance
    (independent samples; the reading's quantisation is part of that variance).
    """
    th, rho = np.asarray(theta_rad, float), np.asarray(rho_mm, float)
    A, r = half_side_mm, corner_radius_mm

    def resid(p):
        pred = rounded_square_rho(th, p[0], p[1], p[2], p[3:5], A, r)
        return np.where(np.isfinite(pred), pred - rho, 1e3)

    x0 = np.r_[start.d_mm, start.dL_mm, start.alpha0_rad, start.centre_mm]
    sol = optimize.least_squares(
        resid, x0, jac="3-point", x_scale=[1, 1, 0.01, 1, 1], xtol=1e-12, ftol=1e-12, gtol=1e-12
    )
    J, res = sol.jac, sol.fun
    dof = len(res) - len(x0)
    s2 = float(res @ res) / dof
    cov = np.linalg.inv(J.T @ J) * s2
    std = dict(zip(("d_mm", "dL_mm", "alpha0_rad", "cx_mm", "cy_mm"), np.sqrt(np.diag(cov))))
    p = sol.x
    return ScannerCalibration(
        d_mm=float(p[0]),
        dL_mm=float(p[1]),
        alpha0_rad=float(np.angle(np.exp(1j * p[2]))),
        centre_mm=p[3:5].copy(),
        std={k: float(v) for k, v in std.items()},
        rms_mm=float(np.sqrt(s2)),
        cov=cov,
    )
