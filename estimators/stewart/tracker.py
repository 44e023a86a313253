"""Where a laser tracker's lengths put a point: trilateration from three known points (the seed's
Eq. 1, with the covariance of Eq. 4-5) and multilateration from three or more stations; the
tracker's stations from the reference nests, and a platform's poses from its reflectors.

Lengths in mm; stations and points in the base frame.
"""

from __future__ import annotations

import numpy as np

from calibench.estimators.rotations import rigid_transform


def trilaterate(
    known: np.ndarray, dist: np.ndarray, sigma: np.ndarray, above: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
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


# A Newton or Gauss-Newton loop has converged when its last step is below this (mm and rad):
# a thousand times the rounding of metre-sized coordinates, far below any instrument's noise
CONVERGED_STEP = 1e-9


def multilaterate(
    stations: np.ndarray,
    dist: np.ndarray,
    sigma: np.ndarray,
    start: np.ndarray,
    iterations: int = 20,
) -> tuple[np.ndarray, np.ndarray, bool]:
    """A point from distances (k,) to stations (k, 3), Gauss-Newton from ``start``; covariance
    (J^T W J)^-1 with W = diag(1 / sigma^2); and whether the iteration converged (False: the
    point is the last iterate, not an answer). Not on the identification core: three unknowns
    from four or more distances, thousands of times per study, its convergence said."""
    p = np.array(start, float)
    w = 1 / np.asarray(sigma, float) ** 2
    step = np.full(3, np.inf)
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
    return p, np.linalg.inv(J.T @ (w[:, None] * J)), bool(np.max(np.abs(step)) < CONVERGED_STEP)


def multilaterate_many(
    stations: np.ndarray,
    dist: np.ndarray,
    sigma: np.ndarray,
    start: np.ndarray,
    iterations: int = 20,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`multilaterate` for several points at once: distances (n, k) to the same stations
    (k, 3), their sigma (n, k), starts (n, 3) -> points (n, 3), covariances (n, 3, 3) and
    whether each converged (n,)."""
    p = np.array(start, float)
    w = 1 / np.asarray(sigma, float) ** 2
    step = np.full(p.shape, np.inf)
    for _ in range(iterations):
        v = p[:, None, :] - stations[None]
        r = np.linalg.norm(v, axis=2)
        J = v / r[..., None]  # (n, k, 3)
        A = np.einsum("nki,nk,nkj->nij", J, w, J)
        step = np.linalg.solve(A, np.einsum("nki,nk->ni", J, w * (dist - r))[..., None])[..., 0]
        p = p + step
        if np.max(np.abs(step)) < 1e-12:
            break
    v = p[:, None, :] - stations[None]
    J = v / np.linalg.norm(v, axis=2)[..., None]
    cov = np.linalg.inv(np.einsum("nki,nk,nkj->nij", J, w, J))
    return p, cov, np.max(np.abs(step), axis=1) < CONVERGED_STEP


def locate_stations(
    nests: np.ndarray, lengths: np.ndarray, sigma: np.ndarray, above: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The tracker's stations from their lengths to three reference nests (the seed's Eq. 1),
    each with its covariance (Eq. 4-5).

    Parameters
    ----------
    nests : (3, 3) the nests' known positions (base frame, mm).
    lengths : (s, 3) each station's lengths to the three nests (mm).
    sigma : (s, 3) their 1-sigma (mm).
    above : (3,) the side of the nests' plane the stations are on.

    Returns
    -------
    stations : (s, 3) mm
    cov : (s, 3, 3) mm^2
    """
    out = [
        trilaterate(nests, d, sd, above=np.asarray(above, float)) for d, sd in zip(lengths, sigma)
    ]
    return np.array([p for p, _ in out]), np.array([c for _, c in out])


def poses_from_lengths(
    reflectors: np.ndarray,
    stations: np.ndarray,
    lengths: np.ndarray,
    sigma: np.ndarray,
    R_guess: np.ndarray,
    t_guess: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A platform's poses from the tracker's lengths to three reflectors: each reflector
    multilaterated from the stations (weighted by its 1-sigma), then the rigid transform of the
    reflectors' platform coordinates onto the three points.

    Parameters
    ----------
    reflectors : (3, 3) the reflectors in the platform frame (mm).
    stations : (3, 3) the stations (base frame, mm).
    lengths, sigma : (n, 3 reflectors, 3 stations) the lengths and their 1-sigma (mm).
    R_guess, t_guess : (n, 3, 3), (n, 3) the poses to start from (the commanded ones).

    Returns
    -------
    R : (n, 3, 3), t : (n, 3) mm the poses (platform frame into the base frame);
    ok : (n,) whether each pose's three multilaterations converged.
    """
    d = np.asarray(lengths, float)
    n = len(d)
    start = np.einsum("kj,nij->nki", reflectors, np.asarray(R_guess)) + np.asarray(t_guess)[:, None]
    pts, _, ok = multilaterate_many(
        stations, d.reshape(-1, 3), np.asarray(sigma, float).reshape(-1, 3), start.reshape(-1, 3)
    )
    R, t = rigid_transform(reflectors, pts.reshape(n, 3, 3))
    return R, t, np.logical_and.reduce(np.asarray(ok).reshape(n, 3), axis=1)
