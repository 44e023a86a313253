"""Calibration of a 6-6 Stewart platform with a laser tracker's lengths (the laser-tracker seed).

Lengths in mm, a pose is (R (3, 3), t (3,)) mapping platform-frame points into the base frame.
Leg i joins the base hinge B_i to the platform hinge r_i (platform frame); its length is
l_i + reading: |R r_i + t - B_i| = l_i + L_reading (the seed's one-step equation).

- :func:`trilaterate`: a point from its distances to three known points (Eq. 1), with the
  covariance propagated through the distance Jacobian (Eq. 4-5).
- :func:`multilaterate`: a point from its distances to three or more stations (least squares).
- :func:`rigid_transform`: a pose from three or more points known in both frames.
- :func:`fit_sphere`: the centre and radius of the sphere through four or more non-coplanar
  points (Eq. 2: the two-step method's hinge point).
- :func:`calibrate_leg`: the one-step method's seven unknowns of one leg, with std.
- :func:`forward_kinematics`: the pose from six leg lengths (Newton).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from estimators.rotations import rigid_transform, rotvec_to_matrix


def trilaterate(known: np.ndarray, dist: np.ndarray, sigma: np.ndarray, above: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The point at distances ``dist`` (3,) from ``known`` (3, 3), on the side of their plane
    where ``above`` (3,) points; and its covariance (3, 3) from the distances' 1-sigma (3,).

    Closed form in the frame of the three points; the covariance is J^-1 diag(sigma^2) J^-T with
    J = d(dist)/d(point), rows the unit vectors from the known points (Eq. 4-5).
    """
    p1, p2, p3 = np.asarray(known, float)
    d1, d2, d3 = np.asarray(dist, float)
    ex = (p2 - p1) / np.linalg.norm(p2 - p1)
    i = ex @ (p3 - p1)
    ey = p3 - p1 - i * ex
    if np.linalg.norm(ey) < 1e-9:
        raise ValueError("the three known points are collinear")
    ey /= np.linalg.norm(ey)
    ez = np.cross(ex, ey)
    d = np.linalg.norm(p2 - p1)
    j = ey @ (p3 - p1)
    x = (d1**2 - d2**2 + d**2) / (2 * d)
    y = (d1**2 - d3**2 + i * i + j * j) / (2 * j) - i * x / j
    z2 = d1**2 - x * x - y * y
    if z2 < 0:
        raise ValueError("the distances do not meet: no intersection of the three spheres")
    z = np.sqrt(z2)
    if np.asarray(above) @ ez < 0:
        z = -z
    p = p1 + x * ex + y * ey + z * ez
    J = (p - known) / np.linalg.norm(p - known, axis=1)[:, None]
    Jinv = np.linalg.inv(J)
    return p, Jinv @ np.diag(np.asarray(sigma, float) ** 2) @ Jinv.T


def multilaterate(stations: np.ndarray, dist: np.ndarray, sigma: np.ndarray, start: np.ndarray,
                  iterations: int = 20) -> tuple[np.ndarray, np.ndarray]:
    """A point from distances (k,) to stations (k, 3), Gauss-Newton from ``start``; covariance
    (J^T W J)^-1 with W = diag(1 / sigma^2)."""
    p = np.array(start, float)
    w = 1 / np.asarray(sigma, float) ** 2
    for _ in range(iterations):
        v = p - stations
        r = np.linalg.norm(v, axis=1)
        J = v / r[:, None]
        step = np.linalg.solve(J.T @ (w[:, None] * J), J.T @ (w * (dist - r)))
        p = p + step
        if np.max(np.abs(step)) < 1e-12:
            break
    v = p - stations
    J = v / np.linalg.norm(v, axis=1)[:, None]
    return p, np.linalg.inv(J.T @ (w[:, None] * J))


def fit_sphere(points: np.ndarray) -> tuple[np.ndarray, float]:
    """Centre (3,) and radius of the least-squares sphere through points (n >= 4, not coplanar).

    Linear in (c, k) from |p|^2 = 2 p.c + k (k = r^2 - |c|^2), then refined geometrically.
    """
    P = np.asarray(points, float)
    if len(P) < 4:
        raise ValueError("a sphere needs four or more points")
    A = np.c_[2 * P, np.ones(len(P))]
    if np.linalg.matrix_rank(A, tol=1e-9 * np.abs(A).max()) < 4:
        raise ValueError("coplanar points: no unique sphere")
    sol, *_ = np.linalg.lstsq(A, np.sum(P * P, axis=1), rcond=None)
    c = sol[:3]
    r = np.sqrt(sol[3] + c @ c)
    for _ in range(20):  # geometric refinement: residual |p - c| - r
        v = P - c
        d = np.linalg.norm(v, axis=1)
        J = np.c_[-v / d[:, None], -np.ones(len(P))]
        step = np.linalg.lstsq(J, -(d - r), rcond=None)[0]
        c, r = c + step[:3], r + step[3]
        if np.max(np.abs(step)) < 1e-12:
            break
    return c, float(r)


@dataclasses.dataclass(frozen=True)
class LegCalibration:
    """Platform hinge r (3,) (platform frame), base hinge B (3,), initial length l; 1-sigma of
    the seven as (7,) in the order a, b, c, m, n, q, l; whitened residual RMS."""

    r: np.ndarray
    B: np.ndarray
    l: float
    std: np.ndarray
    rms: float


def calibrate_leg(R: np.ndarray, t: np.ndarray, readings: np.ndarray, r0: np.ndarray, B0: np.ndarray,
                  l0: float, sigma: np.ndarray) -> LegCalibration:
    """The one-step method for one leg: poses (n, 3, 3), (n, 3), readings (n,), sigma (n,) of
    each equation (length units); Gauss-Newton on |R r + t - B| - (l + reading) = 0."""
    x = np.r_[r0, B0, l0].astype(float)
    w = 1 / np.asarray(sigma, float)

    def linearise(x):
        v = np.einsum("nij,j->ni", R, x[:3]) + t - x[3:6]
        L = np.linalg.norm(v, axis=1)
        u = v / L[:, None]
        res = (L - (x[6] + readings)) * w
        return res, np.c_[np.einsum("ni,nij->nj", u, R), -u, -np.ones(len(u))] * w[:, None]

    for _ in range(50):
        res, J = linearise(x)
        step = np.linalg.lstsq(J, -res, rcond=None)[0]
        x = x + step
        if np.max(np.abs(step)) < 1e-12:
            break
    res, J = linearise(x)
    dof = max(len(res) - 7, 1)
    s2 = res @ res / dof
    cov = np.linalg.inv(J.T @ J) * s2
    return LegCalibration(r=x[:3], B=x[3:6], l=float(x[6]), std=np.sqrt(np.diag(cov)), rms=float(np.sqrt(s2)))


def leg_lengths(R: np.ndarray, t: np.ndarray, r: np.ndarray, B: np.ndarray) -> np.ndarray:
    """Hinge-to-hinge lengths (6,) of a pose, r and B (6, 3)."""
    return np.linalg.norm(r @ R.T + t - B, axis=1)


def forward_kinematics(lengths: np.ndarray, r: np.ndarray, B: np.ndarray, R0: np.ndarray, t0: np.ndarray,
                       iterations: int = 30) -> tuple[np.ndarray, np.ndarray]:
    """The pose whose legs have ``lengths`` (6,), Newton from (R0, t0) (left rotation updates)."""
    R, t = np.array(R0, float), np.array(t0, float)
    for _ in range(iterations):
        p = r @ R.T + t
        v = p - B
        L = np.linalg.norm(v, axis=1)
        u = v / L[:, None]
        Rr = r @ R.T
        J = np.c_[np.cross(Rr, u), u]  # d L / d(omega, t): u . (omega x Rr) = omega . (Rr x u)
        step = np.linalg.solve(J, lengths - L)
        R = rotvec_to_matrix(step[:3]) @ R
        t = t + step[3:]
        if np.max(np.abs(step)) < 1e-13:
            break
    return R, t
