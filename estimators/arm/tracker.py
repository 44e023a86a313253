"""An arm seen by a laser tracker (range and two angles) or articulated in a length bar's cones."""

from __future__ import annotations

import dataclasses

import numpy as np

from calibench.estimators.arm.kinematics import (
    ArmParameters,
    Chain,
    Pose,
    cross,
    jacobian,
    joint_axes,
    n_params,
    param_names,
    pose,
)
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


# --- a tracker's spherical measurements -----------------------------------------------------------
@dataclasses.dataclass
class TrackerState:
    """delta (5 N + 3,); base2tracker R (3, 3), t (3,) mm."""

    delta: np.ndarray
    R: np.ndarray
    t: np.ndarray


class TrackerProblem(ArmParameters):
    """A laser tracker's spherical readings (range, azimuth, elevation) of the tool point, with
    its own base frame; the seed's identification."""

    NUISANCE = ("tracker_rx", "tracker_ry", "tracker_rz", "tracker_x", "tracker_y", "tracker_z")

    def __init__(
        self,
        chain: Chain,
        q_rad: np.ndarray,
        measured: np.ndarray,
        sigma: np.ndarray,
        encoder_sigma_rad: float = 0.0,
    ):
        """q (n, N) encoder readings; measured (n, 3) range (mm), azimuth, elevation (rad);
        sigma (n, 3) their 1-sigma; the encoders' 1-sigma, which reaches the measurement
        through the arm (each posture's residuals are whitened by the full 3 x 3 covariance,
        tracker and encoders together)."""
        self.chain, self.q, self.meas, self.sigma = chain, np.asarray(q_rad, float), measured, sigma
        self.N = self.q.shape[1]
        self.nk = n_params(self.N)
        self.encoder_sigma = float(encoder_sigma_rad)
        self._W: np.ndarray | None = None  # per-posture whitening (n, 3, 3), at the first start
        self._start: tuple[np.ndarray, np.ndarray] | None = None  # the start's frame (R, t), once
        self._G: np.ndarray | None = None  # d(spherical)/d(encoders) at the start (n, 3, N)
        self._last: tuple[np.ndarray, Pose] | None = None  # (delta, Pose) of the last evaluation
        # (delta, R, t, J) of the last Jacobian
        self._last_jacobian: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None = None
        # the tracker's rotation is reported as the small turn from this reference (the first
        # start's): the same coordinates its std is computed in. Share it between problems whose
        # estimates are compared.
        self.R_ref: np.ndarray | None = None
        if not (np.isfinite(self.q).all() and np.isfinite(measured).all()):
            raise ValueError("tracker data must be finite")

    @property
    def names(self) -> tuple[str, ...]:
        """Parameter names, in the column order of :meth:`jacobian`: the chain's errors,
        then the tracker frame."""
        return param_names(self.N) + self.NUISANCE

    @property
    def always(self) -> np.ndarray:
        """The tracker's frame and the tool point."""
        return np.arange(self.nk - 3, self.nk + 6)

    @property
    def groups(self) -> list[np.ndarray]:
        """Column groups the identifiable basis is found in: kinematics, then Hayati's beta."""
        return [
            np.array([5 * i + k for i in range(self.N) for k in range(4)]),
            np.arange(4, 5 * self.N, 5),
        ]

    def cartesian(self) -> np.ndarray:
        """The measurements as points in the tracker's frame, (n, 3) mm."""
        r, az, el = self.meas.T
        return np.stack(
            [r * np.cos(el) * np.cos(az), r * np.cos(el) * np.sin(az), r * np.sin(el)], axis=1
        )

    def start(self) -> TrackerState:
        """Nominal arm; the frame from a rigid fit of the measured points to the nominal ones."""
        if self._start is None:
            self._start = rigid_transform(self._pose(np.zeros(self.nk)).point, self.cartesian())
        R, t = self._start
        if self.R_ref is None:
            self.R_ref = R
        state = TrackerState(np.zeros(self.nk), R.copy(), t.copy())
        if self._W is None:
            self._W = self._whitening(state)
        return state

    def _whitening(self, s: TrackerState) -> np.ndarray:
        """L^-1 of each posture's covariance diag(sigma^2) + G Sigma_q G^T, G = d(sph)/d(q)."""
        cov = np.zeros((len(self.q), 3, 3))
        cov[:, [0, 1, 2], [0, 1, 2]] = self.sigma**2
        if self.encoder_sigma > 0:
            if self._G is None:
                P = self._pose(s.delta)
                y = P.point @ s.R.T + s.t
                # a joint's turn moves the point as that joint's zero offset does: w x (p - o)
                w, o = joint_axes(P)
                Jq = cross(w, P.point[:, None] - o).transpose(0, 2, 1)
                self._G = spherical_jacobian(y) @ (s.R @ Jq)
            cov = cov + self.encoder_sigma**2 * (self._G @ self._G.transpose(0, 2, 1))
        return np.linalg.inv(np.linalg.cholesky(cov))

    def reweighted(self, sigma: np.ndarray, encoder_sigma_rad: float) -> TrackerProblem:
        """The same readings whitened by other 1-sigma (n, 3) and encoder sigma (e.g. the
        simulation's own, for a bound): the start, its frame reference and the encoders' lever
        G are the same, so they are shared, not found again."""
        other = TrackerProblem(self.chain, self.q, self.meas, sigma, encoder_sigma_rad)
        self.start()
        other._start, other.R_ref, other._G, other._last = (
            self._start,
            self.R_ref,
            self._G,
            self._last,
        )
        return other

    def points(self, s: TrackerState) -> np.ndarray:
        """Tool points in the tracker frame, (n, 3)."""
        return self._pose(s.delta).point @ s.R.T + s.t

    def _pose(self, delta: np.ndarray) -> Pose:
        """The chain at the recording's postures, the last one kept: the solver asks for the
        Jacobian where it has just evaluated the residuals."""
        if self._last is None or not _same(self._last[0], delta):
            self._last = (delta.copy(), pose(self.chain, self.q, delta))
        return self._last[1]

    def residuals(self, s: TrackerState) -> np.ndarray:
        """Residuals (3 n,) in spherical coordinates, whitened by each posture's covariance
        (instrument and encoders)."""
        if self._W is None:
            self.start()
        assert self._W is not None  # start() made it
        d = spherical(self.points(s)) - self.meas
        d[:, 1] = (d[:, 1] + np.pi) % (2 * np.pi) - np.pi
        return np.einsum("nij,nj->ni", self._W, d).ravel()

    def jacobian(self, s: TrackerState) -> np.ndarray:
        """Whitened d(residuals) / d(delta, frame rotation, frame translation), (3n, 5 N + 9).

        The last one is kept: the basis is found where the solver starts and again where it
        stops, at the very states the solver takes its own Jacobians."""
        c = self._last_jacobian
        if c is not None and _same(c[0], s.delta) and _same(c[1], s.R) and _same(c[2], s.t):
            return c[3].copy()
        J = self._jacobian(s)
        self._last_jacobian = (s.delta.copy(), s.R.copy(), s.t.copy(), J.copy())
        return J

    def _jacobian(self, s: TrackerState) -> np.ndarray:
        """:meth:`jacobian`, computed."""
        P = self._pose(s.delta)
        y = P.point @ s.R.T + s.t
        if self._W is None:
            self.start()
        assert self._W is not None  # start() made it
        Js = self._W @ spherical_jacobian(y)
        Jy = np.empty((len(y), 3, self.nk + 6))
        Jy[:, :, : self.nk] = s.R @ jacobian(self.chain, P=P)
        Jy[:, :, self.nk : self.nk + 3] = -skew(P.point @ s.R.T)  # left perturbation of R
        Jy[:, :, self.nk + 3 :] = np.eye(3)
        return (Js @ Jy).reshape(len(y) * 3, -1)

    def update(self, s: TrackerState, step: np.ndarray) -> TrackerState:
        """The state moved by ``step``: additive for the errors, a left rotation for the
        tracker frame."""
        nk = self.nk
        return TrackerState(
            s.delta + step[:nk],
            rotvec_to_matrix(step[nk : nk + 3]) @ s.R,
            s.t + step[nk + 3 : nk + 6],
        )

    def values(self, s: TrackerState) -> np.ndarray:
        """The state as one vector (len(names),)."""
        assert self.R_ref is not None, "values are reported after a start"
        return np.concatenate([s.delta, matrix_to_rotvec(s.R @ self.R_ref.T), s.t])


# --- cones and a length bar -----------------------------------------------------------------------
@dataclasses.dataclass
class ConeState:
    delta: np.ndarray
    cones: np.ndarray  # (2, 3) mm, base frame


class ConeProblem(ArmParameters):
    """Tool points held in two kinematic cones and a length bar between them: the arm CMM's own
    artefacts, no external instrument."""

    NUISANCE = ("cone_a_x", "cone_a_y", "cone_a_z", "cone_b_x", "cone_b_y", "cone_b_z")

    def __init__(
        self,
        chain: Chain,
        q_rad: np.ndarray,
        cone: np.ndarray,
        sigma_mm: float,
        bar_length_mm: float,
        bar_sigma_mm: float,
    ):
        """q (n, N) readings with the probe in cone ``cone`` (n,) of {0, 1}; sigma of a probe
        point; the bar's calibrated length and its uncertainty."""
        self.chain, self.q, self.cone = chain, np.asarray(q_rad, float), np.asarray(cone, int)
        self.N = self.q.shape[1]
        self.nk = n_params(self.N)
        self.sigma, self.L, self.sigma_L = sigma_mm, bar_length_mm, bar_sigma_mm
        if set(np.unique(self.cone)) != {0, 1}:
            raise ValueError("cone data need postures in both cones of the bar")

    @property
    def names(self) -> tuple[str, ...]:
        """Parameter names: the chain's errors, then the two cone centres (mm)."""
        return param_names(self.N) + self.NUISANCE

    @property
    def always(self) -> np.ndarray:
        """Columns always estimated: the tool and the cone centres."""
        return np.arange(self.nk, self.nk + 6)

    @property
    def groups(self) -> list[np.ndarray]:
        """Column groups the identifiable basis is found in: kinematics, then Hayati's beta."""
        kin = np.array([5 * i + k for i in range(self.N) for k in range(4)])
        return [kin, np.arange(self.nk - 3, self.nk), np.arange(4, 5 * self.N, 5)]

    def start(self) -> ConeState:
        """The nominal chain and each cone's centre from the nominal points."""
        p = pose(self.chain, self.q).point
        return ConeState(
            np.zeros(self.nk), np.stack([p[self.cone == k].mean(axis=0) for k in (0, 1)])
        )

    def residuals(self, s: ConeState) -> np.ndarray:
        """Whitened residuals: each point from its cone's centre, then the bar's length."""
        p = pose(self.chain, self.q, s.delta).point
        r = (p - s.cones[self.cone]) / self.sigma
        bar = (np.linalg.norm(s.cones[0] - s.cones[1]) - self.L) / self.sigma_L
        return np.r_[r.ravel(), bar]

    def jacobian(self, s: ConeState) -> np.ndarray:
        """d(residuals) / d(parameters), (3 n + 1, len(names))."""
        n, nk = len(self.q), self.nk
        J = np.zeros((3 * n + 1, nk + 6))
        J[: 3 * n, :nk] = jacobian(self.chain, self.q, s.delta).reshape(-1, nk) / self.sigma
        for k in (0, 1):
            rows = np.flatnonzero(np.repeat(self.cone == k, 3))
            J[rows, nk + 3 * k + np.tile(np.arange(3), n)[rows]] = -1 / self.sigma
        u = (s.cones[0] - s.cones[1]) / np.linalg.norm(s.cones[0] - s.cones[1])
        J[-1, nk : nk + 3], J[-1, nk + 3 : nk + 6] = u / self.sigma_L, -u / self.sigma_L
        return J

    def update(self, s: ConeState, step: np.ndarray) -> ConeState:
        """The state moved by ``step`` (additive)."""
        return ConeState(s.delta + step[: self.nk], s.cones + step[self.nk :].reshape(2, 3))

    def values(self, s: ConeState) -> np.ndarray:
        """The state as one vector (len(names),)."""
        return np.r_[s.delta, s.cones.ravel()]


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    """np.array_equal for two float arrays, without its conversions (a cache's test, called at every
    residual and Jacobian)."""
    return a.shape == b.shape and bool((a == b).all())
