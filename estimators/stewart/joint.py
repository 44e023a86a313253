"""The joint adjustment of a Stewart platform's calibration: maximum likelihood over the
tracker's stations, every pose and the six legs together, from every length and reading.

Lengths in mm; a pose is (R (3, 3), t (3,)) mapping platform-frame points into the base frame.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from calibench.estimators.rotations import rotvecs_to_matrices


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
