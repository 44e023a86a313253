"""Identification of an arm CMM's 25 parameter errors, with identifiability analysis first.

Two data sources, one method:
- :class:`TrackerProblem`: a laser tracker's range and two angles of a reflector on the stylus;
  nuisance: the base-to-tracker transform and the reflector's offset in link 7 (the laser-
  tracker seed's frame and flange-to-reflector calibration, estimated jointly).
- :class:`ConeProblem`: single-point articulation in two cones of a calibrated length bar; nuisance:
  the two cone centres (their distance constrained to the bar's length).

:func:`identifiable_basis` takes the whitened Jacobian at the start, removes what the nuisance
can explain (its column space), and runs QR with column pivoting on the scaled remainder: the
columns beyond the numerical rank are the parameters the data cannot tell apart from the others;
each is reported with the parameters it is a combination of. :func:`identify` then solves for the
identifiable basis only (Levenberg-Marquardt), the dropped parameters held at zero, and returns
standard deviations from (J^T J)^-1 scaled by the residual variance.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy import linalg

from calibench.estimators.arm_kinematics import PARAM_NAMES, DHChain, frames, jacobian
from calibench.estimators.rotations import matrix_to_rotvec, rigid_transform, rotvec_to_matrix, skew


def spherical(y: np.ndarray) -> np.ndarray:
    """Range, azimuth, elevation of points (n, 3) -> (n, 3)."""
    r = np.linalg.norm(y, axis=1)
    return np.stack([r, np.arctan2(y[:, 1], y[:, 0]), np.arcsin(y[:, 2] / r)], axis=1)


def spherical_jacobian(y: np.ndarray) -> np.ndarray:
    """d(range, az, el) / dy, (n, 3, 3)."""
    r2 = np.sum(y * y, axis=1)
    r = np.sqrt(r2)
    s2 = y[:, 0] ** 2 + y[:, 1] ** 2
    s = np.sqrt(s2)
    J = np.zeros((len(y), 3, 3))
    J[:, 0] = y / r[:, None]
    J[:, 1, 0], J[:, 1, 1] = -y[:, 1] / s2, y[:, 0] / s2
    J[:, 2, 0] = -y[:, 0] * y[:, 2] / (r2 * s)
    J[:, 2, 1] = -y[:, 1] * y[:, 2] / (r2 * s)
    J[:, 2, 2] = s / r2
    return J


# --- the tracker -------------------------------------------------------------------------------
@dataclasses.dataclass
class TrackerState:
    """delta (25,); base2tracker R (3, 3), t (3,) mm; reflector offset in link 7 (3,) mm."""

    delta: np.ndarray
    R: np.ndarray
    t: np.ndarray
    offset: np.ndarray


class TrackerProblem:
    NUISANCE = ("tracker_rx", "tracker_ry", "tracker_rz", "tracker_x", "tracker_y", "tracker_z",
                "reflector_x", "reflector_y", "reflector_z")
    N_FRAME = 6  # nuisance columns that are always estimated (the frame)

    def __init__(self, chain: DHChain, q_rad: np.ndarray, measured: np.ndarray, sigma: np.ndarray,
                 offset_nominal_mm: np.ndarray, encoder_sigma_rad: float = 0.0):
        """q (n, 6) encoder readings; measured (n, 3) range (mm), azimuth, elevation (rad);
        sigma (n, 3) their 1-sigma; the reflector's nominal offset in link 7 (3,); the encoders'
        1-sigma, which reaches the measurement through the arm (each posture's residuals are
        whitened by the full 3 x 3 covariance, tracker and encoders together)."""
        self.chain, self.q, self.meas, self.sigma = chain, np.asarray(q_rad, float), measured, sigma
        self.encoder_sigma = float(encoder_sigma_rad)
        self._W = None  # per-posture whitening (n, 3, 3), made at the first start
        self.offset_nominal = np.asarray(offset_nominal_mm, float)
        # the tracker's rotation is reported as the small turn from this reference (the first
        # start's): the same coordinates its std is computed in. Share it between problems whose
        # estimates are compared.
        self.R_ref: np.ndarray | None = None
        if not (np.isfinite(self.q).all() and np.isfinite(measured).all()):
            raise ValueError("tracker data must be finite")

    @property
    def names(self) -> tuple[str, ...]:
        return PARAM_NAMES + self.NUISANCE

    def start(self) -> TrackerState:
        """Nominal arm; the frame from a rigid fit of the measured points to the nominal ones."""
        r, az, el = self.meas.T
        y = np.stack([r * np.cos(el) * np.cos(az), r * np.cos(el) * np.sin(az), r * np.sin(el)], axis=1)
        F = frames(self.chain, self.q)
        p = F[:, 7, :3, 3] + F[:, 7, :3, :3] @ self.offset_nominal
        R, t = rigid_transform(p, y)
        if self.R_ref is None:
            self.R_ref = R
        state = TrackerState(np.zeros(25), R, t, self.offset_nominal.copy())
        if self._W is None:
            self._W = self._whitening(state)
        return state

    def _whitening(self, s: TrackerState) -> np.ndarray:
        """L^-1 of each posture's covariance diag(sigma^2) + G Sigma_q G^T, G = d(sph)/d(q)."""
        cov = np.einsum("ni,ij->nij", self.sigma**2, np.eye(3))
        if self.encoder_sigma > 0:
            F = frames(self.chain, self.q, s.delta)
            p = F[:, 7, :3, 3] + F[:, 7, :3, :3] @ s.offset
            y = p @ s.R.T + s.t
            # a joint's turn moves the point as that joint's zero offset does
            Jq = jacobian(self.chain, self.q, s.delta, s.offset, F)[:, :, [3, 7, 11, 15, 19, 23]]
            G = np.einsum("nij,jk,nkl->nil", spherical_jacobian(y), s.R, Jq)
            cov = cov + self.encoder_sigma**2 * np.einsum("nij,nkj->nik", G, G)
        return np.linalg.inv(np.linalg.cholesky(cov))

    def points(self, s: TrackerState) -> np.ndarray:
        """Reflector positions in the tracker frame, (n, 3)."""
        F = frames(self.chain, self.q, s.delta)
        p = F[:, 7, :3, 3] + F[:, 7, :3, :3] @ s.offset
        return p @ s.R.T + s.t

    def residuals(self, s: TrackerState) -> np.ndarray:
        if self._W is None:
            self.start()
        d = spherical(self.points(s)) - self.meas
        d[:, 1] = (d[:, 1] + np.pi) % (2 * np.pi) - np.pi
        return np.einsum("nij,nj->ni", self._W, d).ravel()

    def jacobian(self, s: TrackerState) -> np.ndarray:
        """Whitened d(residuals) / d(delta, frame rotation, frame translation, offset), (3n, 34)."""
        F = frames(self.chain, self.q, s.delta)
        p = F[:, 7, :3, 3] + F[:, 7, :3, :3] @ s.offset
        y = p @ s.R.T + s.t
        if self._W is None:
            self.start()
        Js = np.einsum("nij,njk->nik", self._W, spherical_jacobian(y))
        Jd = np.einsum("ij,njk->nik", s.R, jacobian(self.chain, self.q, s.delta, s.offset, F))
        Jw = -skew(p @ s.R.T)  # left perturbation of R
        Jt = np.broadcast_to(np.eye(3), (len(y), 3, 3))
        Jo = np.einsum("ij,njk->nik", s.R, F[:, 7, :3, :3])
        Jy = np.concatenate([Jd, Jw, Jt, Jo], axis=2)
        return np.einsum("nij,njk->nik", Js, Jy).reshape(-1, 34)

    def update(self, s: TrackerState, step: np.ndarray) -> TrackerState:
        return TrackerState(s.delta + step[:25], rotvec_to_matrix(step[25:28]) @ s.R, s.t + step[28:31], s.offset + step[31:34])


# --- cones and a length bar -----------------------------------------------------------------------
@dataclasses.dataclass
class ConeState:
    delta: np.ndarray
    cones: np.ndarray  # (2, 3) mm, base frame


class ConeProblem:
    NUISANCE = ("cone_a_x", "cone_a_y", "cone_a_z", "cone_b_x", "cone_b_y", "cone_b_z")
    N_FRAME = 6

    def __init__(self, chain: DHChain, q_rad: np.ndarray, cone: np.ndarray, sigma_mm: float,
                 bar_length_mm: float, bar_sigma_mm: float):
        """q (n, 6) readings with the probe in cone ``cone`` (n,) of {0, 1}; sigma of a probe
        point; the bar's calibrated length and its uncertainty."""
        self.chain, self.q, self.cone = chain, np.asarray(q_rad, float), np.asarray(cone, int)
        self.sigma, self.L, self.sigma_L = sigma_mm, bar_length_mm, bar_sigma_mm
        if set(np.unique(self.cone)) != {0, 1}:
            raise ValueError("cone data need postures in both cones of the bar")

    @property
    def names(self) -> tuple[str, ...]:
        return PARAM_NAMES + self.NUISANCE

    def start(self) -> ConeState:
        p = frames(self.chain, self.q)[:, 7, :3, 3]
        return ConeState(np.zeros(25), np.stack([p[self.cone == k].mean(axis=0) for k in (0, 1)]))

    def residuals(self, s: ConeState) -> np.ndarray:
        p = frames(self.chain, self.q, s.delta)[:, 7, :3, 3]
        r = (p - s.cones[self.cone]) / self.sigma
        bar = (np.linalg.norm(s.cones[0] - s.cones[1]) - self.L) / self.sigma_L
        return np.r_[r.ravel(), bar]

    def jacobian(self, s: ConeState) -> np.ndarray:
        n = len(self.q)
        J = np.zeros((3 * n + 1, 31))
        J[:3 * n, :25] = jacobian(self.chain, self.q, s.delta).reshape(-1, 25) / self.sigma
        for k in (0, 1):
            rows = np.flatnonzero(np.repeat(self.cone == k, 3))
            J[rows, 25 + 3 * k + np.tile(np.arange(3), n)[rows]] = -1 / self.sigma
        u = (s.cones[0] - s.cones[1]) / np.linalg.norm(s.cones[0] - s.cones[1])
        J[-1, 25:28], J[-1, 28:31] = u / self.sigma_L, -u / self.sigma_L
        return J

    def update(self, s: ConeState, step: np.ndarray) -> ConeState:
        return ConeState(s.delta + step[:25], s.cones + step[25:31].reshape(2, 3))


# --- identifiability and the solver ----------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class Basis:
    """Which columns are estimated (kept, indices into the problem's parameters) and which are
    dropped, each with the parameters it is a combination of."""

    kept: np.ndarray
    dropped: dict[str, str]


def identifiable_basis(problem, state=None, rel_tol: float = 1e-4) -> Basis:
    """Practical rank of the scaled, whitened Jacobian, group by group: the nuisance frame
    (always kept), then the 25 kinematic parameters, then any further nuisance (e.g. the
    reflector's offset). Each group is pivoted (QR) on what the kept columns cannot explain, so a
    later group's column that repeats an earlier one is the one dropped. ``rel_tol`` is relative
    to the largest column: a dependence that holds only up to the data's own scatter (1e-5 here)
    is a dependence."""
    s = problem.start() if state is None else state
    J = problem.jacobian(s)
    names = problem.names
    scale = np.linalg.norm(J, axis=0)
    scale[scale == 0] = 1.0
    Js = J / scale
    nf = problem.N_FRAME
    groups = [np.arange(25), np.arange(25 + nf, J.shape[1])]
    kept = list(range(25, 25 + nf))
    dropped = []
    top = np.linalg.norm(Js, axis=0).max()
    for cols in groups:
        if len(cols) == 0:
            continue
        Q, _ = np.linalg.qr(Js[:, kept])
        rest = Js[:, cols] - Q @ (Q.T @ Js[:, cols])
        _, Rr, piv = linalg.qr(rest, mode="economic", pivoting=True)
        diag = np.abs(np.diag(Rr))
        rank = int(np.sum(diag > rel_tol * top))
        kept += list(cols[piv[:rank]])
        dropped += list(cols[piv[rank:]])
    kept = np.sort(np.array(kept))
    reasons = {}
    coefs = np.linalg.lstsq(Js[:, kept], Js[:, dropped], rcond=None)[0] if dropped else None
    for m, j in enumerate(dropped):
        coef = coefs[:, m]
        order = np.argsort(-np.abs(coef))
        big = [f"{names[kept[k]]} ({coef[k]:+.2f})" for k in order[:3] if abs(coef[k]) > 0.05 * abs(coef[order[0]])]
        reasons[names[j]] = "moves the data as " + " + ".join(big)
    return Basis(kept=kept, dropped=reasons)


@dataclasses.dataclass(frozen=True)
class Identification:
    state: object
    estimate: dict[str, float]  # kept parameters by name
    std: dict[str, float]
    basis: Basis
    rms: float  # whitened residual RMS (1 when the noise model is right)
    iterations: int


def identify(problem, basis: Basis, state=None, max_iter: int = 50) -> Identification:
    """Levenberg-Marquardt over the kept parameters; std from the whitened normal matrix."""
    s = problem.start() if state is None else state
    k = basis.kept
    lam = 1e-3
    r = problem.residuals(s)
    cost = r @ r
    it = 0
    for it in range(1, max_iter + 1):
        J = problem.jacobian(s)[:, k]
        A, g = J.T @ J, J.T @ r
        while True:
            step_k = -np.linalg.solve(A + lam * np.diag(np.diag(A)), g)
            step = np.zeros(len(problem.names))
            step[k] = step_k
            s_new = problem.update(s, step)
            r_new = problem.residuals(s_new)
            if r_new @ r_new < cost:
                s, r, cost, lam = s_new, r_new, r_new @ r_new, max(lam / 10, 1e-12)
                break
            lam *= 10
            if lam > 1e12:
                break
        if np.max(np.abs(step_k) * np.sqrt(np.diag(A))) < 1e-8 or lam > 1e12:
            break
    J = problem.jacobian(s)[:, k]
    dof = max(len(r) - len(k), 1)
    s2 = cost / dof
    cov = np.linalg.inv(J.T @ J) * s2
    names = problem.names
    values = _values(problem, s)
    return Identification(state=s, estimate={names[j]: values[j] for j in k},
                          std={names[j]: float(np.sqrt(cov[i, i])) for i, j in enumerate(k)},
                          basis=basis, rms=float(np.sqrt(s2)), iterations=it)


def identify_identifiable(problem) -> Identification:
    """Basis at the start, solve, then the basis again at the solution: a dependence that only
    holds once the model fits (e.g. all points of one cone coinciding) shows there; if the basis
    changes, solve again with it."""
    basis = identifiable_basis(problem)
    first = identify(problem, basis)
    again = identifiable_basis(problem, first.state)
    if set(again.kept) == set(basis.kept):
        return first
    # restart from the solution with the newly dropped parameters back at nominal (kept fixed
    # there), so the fit is re-expressed in the new basis rather than carried over
    reset = np.zeros(len(problem.names))
    newly = np.setdiff1d(basis.kept, again.kept)
    reset[newly] = -_values(problem, first.state)[newly]
    return identify(problem, again, state=problem.update(first.state, reset))


def _values(problem, s) -> np.ndarray:
    """The state as a vector in the problem's parameter order (rotations as their angles)."""
    if isinstance(s, TrackerState):
        w = matrix_to_rotvec(s.R @ problem.R_ref.T)
        return np.r_[s.delta, w, s.t, s.offset]
    return np.r_[s.delta, s.cones.ravel()]


def parameter_scales(names) -> np.ndarray:
    """Typical sizes to make columns comparable: 0.1 mm for lengths, 1 mrad for angles."""
    return np.array([1e-3 if n.startswith(("dalpha", "dtheta", "tracker_r")) else 0.1 for n in names])


def observability_index(J: np.ndarray) -> float:
    """O1 of Borm and Menq: the geometric mean of the singular values of the identification
    Jacobian (columns scaled by :func:`parameter_scales`), over the square root of its rows."""
    sv = np.linalg.svd(J, compute_uv=False)
    return float(np.exp(np.mean(np.log(np.maximum(sv, 1e-300)))) / np.sqrt(J.shape[0]))


def select_postures(J_candidates: np.ndarray, n: int, ridge: float = 1e-6) -> np.ndarray:
    """Greedy D-optimal choice of ``n`` postures from candidates' Jacobian blocks (m, rows, k):
    each step adds the posture that most increases log det(J^T J) (so O1), by the matrix
    determinant lemma on a running inverse. Returns candidate indices, in the order chosen."""
    m, rows, k = J_candidates.shape
    info = ridge * np.eye(k)
    chosen = []
    free = np.ones(m, bool)
    for _ in range(n):
        Minv = np.linalg.inv(info)
        G = np.einsum("mrk,kl,msl->mrs", J_candidates, Minv, J_candidates)
        gain = np.linalg.slogdet(np.eye(rows) + G)[1]
        gain[~free] = -np.inf
        best = int(np.argmax(gain))
        chosen.append(best)
        free[best] = False
        info = info + J_candidates[best].T @ J_candidates[best]
    return np.array(chosen)
