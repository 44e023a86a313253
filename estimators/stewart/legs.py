"""One leg's calibration: the two-step method's sphere (Eq. 2) and hinges from three spheres,
and the one-step method's seven unknowns, |R r_i + t - B_i| = l_i + reading, with their std.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from calibench.estimators.camera.pose import mean_rotation
from calibench.estimators.stewart.tracker import CONVERGED_STEP, poses_from_lengths


def fit_sphere(points: np.ndarray) -> tuple[np.ndarray, float, bool]:
    """Centre (3,) and radius of the least-squares sphere through points (n >= 4, not coplanar),
    and whether the geometric refinement converged.

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
    step = np.full(4, np.inf)
    for _ in range(20):  # geometric refinement: residual |p - c| - r
        v = P - c
        d = np.linalg.norm(v, axis=1)
        J = np.c_[-v / d[:, None], -np.ones(len(P))]
        step = np.linalg.lstsq(J, -(d - r), rcond=None)[0]
        c, r = c + step[:3], r + step[3]
        if np.max(np.abs(step)) < 1e-12:
            break
    return c, float(r), bool(np.max(np.abs(step)) < CONVERGED_STEP)


@dataclasses.dataclass(frozen=True)
class LegCalibration:
    """Platform hinge r (3,) (platform frame), base hinge B (3,), initial length l; 1-sigma of
    the seven as (7,) in the order a, b, c, m, n, q, l; whitened residual RMS."""

    r: np.ndarray
    B: np.ndarray
    l: float
    std: np.ndarray
    rms: float
    converged: bool = True  # False: Gauss-Newton ran out of iterations, this is its last iterate


def calibrate_leg(
    R: np.ndarray,
    t: np.ndarray,
    readings: np.ndarray,
    r0: np.ndarray,
    B0: np.ndarray,
    l0: float,
    sigma: np.ndarray,
    iterations: int = 50,
) -> LegCalibration:
    """The one-step method for one leg: poses (n, 3, 3), (n, 3), readings (n,), sigma (n,) of
    each equation (length units); Gauss-Newton on |R r + t - B| - (l + reading) = 0.

    Not on the identification core: the published per-leg method this project reproduces
    (seven unknowns, always identifiable from spread poses), with its convergence said; the
    joint adjustment of every leg and pose (:mod:`.adjustment`) is the core's."""
    x = np.r_[r0, B0, l0].astype(float)
    w = 1 / np.asarray(sigma, float)

    def linearise(x):
        v = np.einsum("nij,j->ni", R, x[:3]) + t - x[3:6]
        L = np.linalg.norm(v, axis=1)
        u = v / L[:, None]
        res = (L - (x[6] + readings)) * w
        return res, np.c_[np.einsum("ni,nij->nj", u, R), -u, -np.ones(len(u))] * w[:, None]

    converged = False
    for _ in range(iterations):
        res, J = linearise(x)
        step = np.linalg.lstsq(J, -res, rcond=None)[0]
        x = x + step
        if np.max(np.abs(step)) < 1e-12:
            converged = True
            break
    res, J = linearise(x)
    dof = max(len(res) - 7, 1)
    s2 = res @ res / dof
    cov = np.linalg.inv(J.T @ J) * s2
    return LegCalibration(
        r=x[:3],
        B=x[3:6],
        l=float(x[6]),
        std=np.sqrt(np.diag(cov)),
        rms=float(np.sqrt(s2)),
        converged=converged,
    )


def calibrate_legs(
    R: np.ndarray,
    t: np.ndarray,
    readings: np.ndarray,
    r0: np.ndarray,
    B0: np.ndarray,
    l0: np.ndarray,
    sigma: np.ndarray,
) -> list[LegCalibration]:
    """The one-step method for the six legs, each alone (:func:`calibrate_leg`): poses R (n, 3, 3),
    t (n, 3) mm, readings (n, 6) mm, the nominal hinges r0, B0 (6, 3) and lengths l0 (6,) to start
    from, sigma (n,) mm of each leg's equation at each pose."""
    return [calibrate_leg(R, t, readings[:, i], r0[i], B0[i], l0[i], sigma) for i in range(6)]


@dataclasses.dataclass(frozen=True)
class TwoStepLeg:
    """The two-step method's leg: platform hinge r (3,), base hinge B (3,), initial length l (mm);
    the spheres it came from, centres (o, 3), radii (o,) and the platform origins on them
    (o, m, 3); and how many of its solves (multilaterations, sphere fits) did not converge."""

    r: np.ndarray
    B: np.ndarray
    l: float
    centres: np.ndarray
    radii: np.ndarray
    origins: np.ndarray
    unconverged: int


def two_step_leg(
    reflectors: np.ndarray,
    stations: np.ndarray,
    lengths: np.ndarray,
    sigma: np.ndarray,
    R_commanded: np.ndarray,
    t_commanded: np.ndarray,
    locked_reading: float,
) -> TwoStepLeg:
    """The two-step method for one leg, locked at one reading while the platform moves at o >= 3
    fixed orientations: at each, the platform origin runs on a sphere of the leg's length about
    C_o = B - R_o r (Eq. 2). The poses from the tracker's lengths, a sphere through each
    orientation's origins, then r from the centres' differences (least squares), B as the mean of
    C_o + R_o r and l as the mean radius less the locked reading. The orientations are the
    measured ones (each group's mean rotation), not the commanded ones.

    Parameters
    ----------
    reflectors : (3, 3) the reflectors in the platform frame (mm).
    stations : (3, 3) the tracker's stations (mm).
    lengths, sigma : (o, m, 3 reflectors, 3 stations) the lengths at the m places of each
        orientation, and their 1-sigma (mm).
    R_commanded : (o, 3, 3) the orientations; t_commanded : (o, m, 3) mm the places (the poses'
        starting guesses).
    locked_reading : the leg's reading while locked (mm).
    """
    o, m = np.shape(lengths)[:2]
    centres, radii, origins, Rs = [], [], [], []
    bad = 0
    for k in range(o):
        Rm, ts, ok = poses_from_lengths(
            reflectors,
            stations,
            lengths[k],
            sigma[k],
            np.repeat(np.asarray(R_commanded[k])[None], m, axis=0),
            t_commanded[k],
        )
        bad += int(np.sum(~ok))
        Rs.append(Rm)
        c, rad, fitted = fit_sphere(ts)
        bad += not fitted
        centres.append(c)
        radii.append(rad)
        origins.append(np.array(ts))
    measured = [mean_rotation(np.array(Rk)) for Rk in Rs]
    A = np.vstack([measured[0] - measured[k] for k in range(1, o)])
    y = np.concatenate([centres[k] - centres[0] for k in range(1, o)])
    r = np.linalg.lstsq(A, y, rcond=None)[0]
    B = np.mean([centres[k] + measured[k] @ r for k in range(o)], axis=0)
    l = float(np.mean(radii) - locked_reading)
    return TwoStepLeg(r, B, l, np.array(centres), np.array(radii), np.array(origins), bad)
