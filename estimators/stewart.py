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

from calibench.estimators.rotations import rotvec_to_matrix, rotvecs_to_matrices


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
    point is the last iterate, not an answer)."""
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
    each equation (length units); Gauss-Newton on |R r + t - B| - (l + reading) = 0."""
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


def leg_lengths(R: np.ndarray, t: np.ndarray, r: np.ndarray, B: np.ndarray) -> np.ndarray:
    """Hinge-to-hinge lengths (6,) of a pose, r and B (6, 3)."""
    return np.linalg.norm(r @ R.T + t - B, axis=1)


def forward_kinematics(
    lengths: np.ndarray,
    r: np.ndarray,
    B: np.ndarray,
    R0: np.ndarray,
    t0: np.ndarray,
    iterations: int = 30,
) -> tuple[np.ndarray, np.ndarray, bool]:
    """The pose whose legs have ``lengths`` (6,), Newton from (R0, t0) (left rotation updates),
    and whether Newton converged."""
    R, t = np.array(R0, float), np.array(t0, float)
    step = np.full(6, np.inf)
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
    return R, t, bool(np.max(np.abs(step)) < CONVERGED_STEP)


def forward_kinematics_many(
    lengths: np.ndarray,
    r: np.ndarray,
    B: np.ndarray,
    R0: np.ndarray,
    t0: np.ndarray,
    iterations: int = 30,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`forward_kinematics` for many leg-length sets (n, 6) at once, each from (R0, t0):
    poses R (n, 3, 3), t (n, 3) and whether each converged (n,). A set no pose can take (a
    negative length, a singularity on the way) is one that did not converge; the others go on."""
    lengths = np.asarray(lengths, float)
    n = len(lengths)
    R, t = (
        np.repeat(np.asarray(R0, float)[None], n, axis=0),
        np.repeat(np.asarray(t0, float)[None], n, axis=0),
    )
    step = np.full((n, 6), np.inf)
    lost = np.zeros(
        n, bool
    )  # poses whose iteration left the finite numbers: not converged, and frozen
    for _ in range(iterations):
        Rr = np.einsum("nij,kj->nki", R, r)  # (n, 6, 3)
        v = Rr + t[:, None] - B
        L = np.linalg.norm(v, axis=2)
        with np.errstate(invalid="ignore", divide="ignore"):
            u = v / L[..., None]
        J = np.concatenate([np.cross(Rr, u), u], axis=2)  # (n, 6, 6)
        rhs = lengths - L
        lost |= ~(np.isfinite(J).all(axis=(1, 2)) & np.isfinite(rhs).all(axis=1))
        J[lost], rhs[lost] = np.eye(6), 0.0
        try:
            step = np.linalg.solve(J, rhs[..., None])[..., 0]
        except np.linalg.LinAlgError:  # a pose at a singularity must not stop the others
            step = np.einsum("nij,nj->ni", np.linalg.pinv(J), rhs)
        R = np.einsum("nij,njk->nik", rotvec_to_matrix(step[:, :3]), R)
        t = t + step[:, 3:]
        if np.max(np.abs(step)) < 1e-13:
            break
    return R, t, (np.max(np.abs(step), axis=1) < CONVERGED_STEP) & ~lost


@dataclasses.dataclass(frozen=True)
class TrackerObservations:
    """Everything one calibration measured, for the joint adjustment.

    nests (3, 3): the reference nests (known, base frame); nest_lengths (3, 3): [station, nest];
    reflectors (k, 3): the reflectors in the platform frame; reflector_lengths (n, k, 3):
    [pose, reflector, station]; readings (n, 6): the legs' length readings; the tracker's
    1-sigma is ``length_sigma[0] + length_sigma[1] * L`` (L in mm), the readings' is
    ``reading_sigma``.
    """

    nests: np.ndarray
    nest_lengths: np.ndarray
    reflectors: np.ndarray
    reflector_lengths: np.ndarray
    readings: np.ndarray
    length_sigma: tuple[float, float]
    reading_sigma: float

    def sigma(self) -> np.ndarray:
        """The 1-sigma of every measured length, in the order of the residuals (mm)."""
        L = np.r_[self.nest_lengths.ravel(), self.reflector_lengths.ravel()]
        return np.r_[
            self.length_sigma[0] + self.length_sigma[1] * L,
            np.full(self.readings.size, self.reading_sigma),
        ]


@dataclasses.dataclass(frozen=True)
class JointCalibration:
    """The joint estimate: stations (3, 3), poses R (n, 3, 3), t (n, 3), legs r, B (6, 3), l (6,);
    cov (42, 42) of the legs' parameters (a, b, c, m, n, q, l per leg), whitened residual RMS."""

    stations: np.ndarray
    R: np.ndarray
    t: np.ndarray
    r: np.ndarray
    B: np.ndarray
    l: np.ndarray
    cov: np.ndarray
    rms: float
    converged: bool = True  # False: ran out of iterations, this is the last iterate

    @property
    def std(self) -> np.ndarray:
        """1-sigma of the 42 leg parameters, (42,), from the covariance's diagonal."""
        return np.sqrt(np.diag(self.cov))


@dataclasses.dataclass(frozen=True)
class _JointBlocks:
    """The joint problem's whitened residuals and Jacobian, by blocks. The unknowns: the globals
    (the stations (9), then per leg r, B, l (42)) and each pose's left rotation and shift (6).

    res_nest (9,), J_nest (9, 51): the nests' lengths (stations only).
    res_pose (n, 3 k + 6): each pose's reflector lengths [reflector, station], then its 6 readings.
    J_pose (n, 3 k + 6, 6) on the pose's own (omega, t); J_glob (n, 3 k + 6, 51) on the globals.
    """

    res_nest: np.ndarray
    J_nest: np.ndarray
    res_pose: np.ndarray
    J_pose: np.ndarray
    J_glob: np.ndarray


def _joint_blocks(obs: TrackerObservations, stations, R, t, r, B, l) -> _JointBlocks:
    """The residuals and Jacobian of every measurement, pose by pose (:class:`_JointBlocks`)."""
    n, k = len(R), len(obs.reflectors)
    w = 1 / obs.sigma()
    w_nest, w_refl, w_leg = (
        w[:9],
        w[9 : 9 + 3 * n * k].reshape(n, 3 * k),
        w[9 + 3 * n * k :].reshape(n, 6),
    )
    # nests: |N_j - S_s|
    v = obs.nests[None, :, :] - stations[:, None, :]  # (3 s, 3 j, 3)
    Ln = np.linalg.norm(v, axis=2)
    J_nest = np.zeros((3, 3, 51))
    un = v / Ln[..., None]
    for s in range(3):
        J_nest[s, :, 3 * s : 3 * s + 3] = -un[s]
    # reflectors: |R f + t - S_s|
    Rf = np.einsum("nij,kj->nki", R, obs.reflectors)  # (n, k, 3)
    v = (Rf + t[:, None, :])[:, :, None, :] - stations[None, None, :, :]  # (n, k, s, 3)
    Lr = np.linalg.norm(v, axis=3)
    ur = v / Lr[..., None]
    J_pose = np.zeros((n, 3 * k + 6, 6))
    J_glob = np.zeros((n, 3 * k + 6, 51))
    Jg = J_glob[:, : 3 * k].reshape(n, k, 3, 51)
    for s in range(3):
        Jg[:, :, s, 3 * s : 3 * s + 3] = -ur[:, :, s]
    # u . (omega x Rf) = omega . (Rf x u)
    J_pose[:, : 3 * k, :3] = np.cross(Rf[:, :, None, :], ur).reshape(n, 3 * k, 3)
    J_pose[:, : 3 * k, 3:] = ur.reshape(n, 3 * k, 3)
    # legs: |R r_i + t - B_i| - l_i = reading
    Rr = np.einsum("nij,lj->nli", R, r)  # (n, 6, 3)
    v = Rr + t[:, None, :] - B[None]
    Ll = np.linalg.norm(v, axis=2)
    ul = v / Ll[..., None]
    J_pose[:, 3 * k :, :3] = np.cross(Rr, ul)
    J_pose[:, 3 * k :, 3:] = ul
    legs = np.arange(6)
    uR = np.einsum("nli,nij->nlj", ul, R)  # d L / d r_i = u^T R
    Jl = J_glob[:, 3 * k :]  # (n, 6, 51)
    for c in range(3):
        Jl[:, legs, 9 + 7 * legs + c] = uR[..., c]
        Jl[:, legs, 9 + 7 * legs + 3 + c] = -ul[..., c]
    Jl[:, legs, 9 + 7 * legs + 6] = -1.0
    res_pose = np.concatenate(
        [
            (Lr - obs.reflector_lengths).reshape(n, 3 * k) * w_refl,
            (Ll - l[None] - obs.readings) * w_leg,
        ],
        axis=1,
    )
    w_pose = np.concatenate([w_refl, w_leg], axis=1)[..., None]
    return _JointBlocks(
        (Ln - obs.nest_lengths).ravel() * w_nest,
        J_nest.reshape(9, 51) * w_nest[:, None],
        res_pose,
        J_pose * w_pose,
        J_glob * w_pose,
    )


def _joint_residuals(obs: TrackerObservations, stations, R, t, r, B, l):
    """Whitened residuals (m,) and the dense Jacobian (m, 9 + 6 n + 42) of every measurement
    (the blocks of :func:`_joint_blocks` put together).

    Unknowns: stations, then (omega, t) per pose (left rotation increments), then per leg
    (r, B, l). Rows: nest lengths, reflector lengths, leg readings.
    """
    b = _joint_blocks(obs, stations, R, t, r, B, l)
    n, m = b.res_pose.shape
    k3 = m - 6
    n_par = 9 + 6 * n + 42
    J = np.zeros((n, m, n_par))
    J[:, :, :9], J[:, :, -42:] = b.J_glob[..., :9], b.J_glob[..., 9:]
    for i in range(n):
        J[i, :, 9 + 6 * i : 15 + 6 * i] = b.J_pose[i]
    nest = np.zeros((9, n_par))
    nest[:, :9] = b.J_nest[:, :9]
    res = np.r_[b.res_nest, b.res_pose[:, :k3].ravel(), b.res_pose[:, k3:].ravel()]
    return res, np.vstack([nest, J[:, :k3].reshape(-1, n_par), J[:, k3:].reshape(-1, n_par)])


def _reduced_normal(b: _JointBlocks) -> tuple[np.ndarray, ...]:
    """The normal equations with every pose eliminated (Schur complement), column-scaled (mm
    and rad mix): S (51, 51) and its right side (51,) on the scaled globals, with what it takes
    to recover the poses' steps and the scales: U^-1 (n, 6, 6), W (n, 6, 51), g_pose (n, 6),
    then the globals' and the poses' column scales (51,) and (n, 6)."""
    sg = 1 / np.sqrt(np.sum(b.J_glob**2, axis=(0, 1)) + np.sum(b.J_nest**2, axis=0))
    sp = 1 / np.linalg.norm(b.J_pose, axis=1)  # (n, 6)
    Jg, Jp, Jn = b.J_glob * sg, b.J_pose * sp[:, None, :], b.J_nest * sg
    JpT = Jp.transpose(0, 2, 1)
    U_inv = np.linalg.inv(JpT @ Jp)
    W = JpT @ Jg
    g_pose = (JpT @ b.res_pose[..., None])[..., 0]
    Jg2 = Jg.reshape(-1, Jg.shape[2])
    V = Jg2.T @ Jg2 + Jn.T @ Jn
    g_glob = Jg2.T @ b.res_pose.ravel() + Jn.T @ b.res_nest
    WtUi = W.transpose(0, 2, 1) @ U_inv  # (n, 51, 6)
    S = V - np.sum(WtUi @ W, axis=0)
    rhs = -(g_glob - np.einsum("nij,nj->i", WtUi, g_pose))
    return S, rhs, U_inv, W, g_pose, sg, sp


def joint_information(obs: TrackerObservations, stations, R, t, r, B, l) -> np.ndarray:
    """The legs' 42 x 42 covariance from the full Fisher information at the given values, with
    the stations and poses as nuisance parameters (Schur complement). At the truth this is the
    Cramer-Rao bound of any unbiased estimator of the legs from these measurements."""
    b = _joint_blocks(
        obs,
        np.asarray(stations, float),
        np.asarray(R, float),
        np.asarray(t, float),
        np.asarray(r, float),
        np.asarray(B, float),
        np.asarray(l, float),
    )
    S, _, _, _, _, sg, _ = _reduced_normal(b)
    return (np.linalg.inv(S) * np.outer(sg, sg))[9:, 9:]


def adjust_jointly(
    obs: TrackerObservations, stations, R, t, r, B, l, iterations: int = 20
) -> JointCalibration:
    """Maximum likelihood over stations, poses and legs together, Gauss-Newton from a start
    close enough (the one-step pipeline's): every length and reading weighted by its 1-sigma.

    The pipeline fixes the stations from three lengths each and the poses from the tracker alone;
    here the legs' readings also inform the poses and every pose informs the stations, which the
    sequential estimate leaves on the table. Each step eliminates the poses (6 x 6 blocks) and
    solves for the 51 stations' and legs' values only.
    """
    S, Rc, tc = np.array(stations, float), np.array(R, float), np.array(t, float)
    rc, Bc, lc = np.array(r, float), np.array(B, float), np.array(l, float)
    converged = False
    for _ in range(iterations):
        b = _joint_blocks(obs, S, Rc, tc, rc, Bc, lc)
        Sch, rhs, U_inv, W, g_pose, sg, sp = _reduced_normal(b)
        dg = np.linalg.solve(Sch, rhs)
        dp = -(U_inv @ (g_pose + W @ dg)[..., None])[..., 0] * sp  # (n, 6)
        dg = dg * sg
        S = S + dg[:9].reshape(3, 3)
        Rc = np.einsum("nij,njk->nik", rotvecs_to_matrices(dp[:, :3]), Rc)
        tc = tc + dp[:, 3:]
        legs = dg[9:].reshape(6, 7)
        rc, Bc, lc = rc + legs[:, :3], Bc + legs[:, 3:6], lc + legs[:, 6]
        if max(np.max(np.abs(dg)), np.max(np.abs(dp))) < 1e-11:
            converged = True
            break
    b = _joint_blocks(obs, S, Rc, tc, rc, Bc, lc)
    res = np.r_[b.res_nest, b.res_pose.ravel()]
    dof = max(len(res) - (51 + 6 * len(Rc)), 1)
    # the stated sigma are a datasheet's, not the truth: the variance factor of the whitened
    # residuals (1 when the datasheet is right) rescales the covariance, and is reported as rms
    s2 = res @ res / dof
    Sch, _, _, _, _, sg, _ = _reduced_normal(b)
    cov = (np.linalg.inv(Sch) * np.outer(sg, sg))[9:, 9:] * s2
    return JointCalibration(S, Rc, tc, rc, Bc, lc, cov, float(np.sqrt(s2)), converged)
