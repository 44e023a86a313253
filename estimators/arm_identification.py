"""Identification of a serial arm's parameter errors, with identifiability analysis first.

Three kinds of data, one method:
- :class:`PointProblem`: points measured by an instrument in its own frame (a laser tracker's
  Cartesian output, a CMM), from one or several recordings, each with its own base-to-
  instrument transform (the laser-tracker seed's base calibration); the tool point is always
  estimated (its Tool0 calibration). Optionally the joints' compliance under gravity.
- :class:`TrackerProblem`: a laser tracker's range and two angles of the tool point, one frame.
- :class:`ConeProblem`: single-point articulation in two cones of a calibrated length bar;
  nuisance: the two cone centres (their distance constrained to the bar's length).

:func:`identifiable_basis` takes the whitened Jacobian at the start and runs QR with column
pivoting group by group (what is always estimated, then the kinematic parameters, then Hayati's
betas, then the compliances), each on what the kept columns cannot explain: a column beyond the
numerical rank is a parameter the data cannot tell from the others and is dropped, with the
parameters it is a combination of. :func:`identify` solves for the kept parameters
(Levenberg-Marquardt), the dropped ones held at zero, and reports convergence and standard
deviations from the whitened normal matrix.

Compliance (``compliance<j>``, rad / N m internally): joint j's link turns by c_j tau_j from its
motor's (encoder's) angle, tau_j the gravity torque computed from the chain's masses at the
encoder reading (:func:`estimators.arm_kinematics.gravity_torques`).
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np
from scipy.linalg import lapack

from calibench.estimators.arm_kinematics import (
    Chain,
    Pose,
    cross,
    gravity_moments,
    jacobian,
    joint_axes,
    n_params,
    param_names,
    pose,
    theta_index,
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


# --- points in the instrument's frame ------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class AngleTerm:
    """A joint's angle error as a combination of known functions of its own angle: the reading
    is off by F(q_j) @ c (rad), the link at q_j - F(q_j) @ c. ``kind``: ``harmonic`` (sin and
    cos of ``harmonic`` q_j: an encoder's eccentricity at 1, a gear's harmonics beyond) or
    ``table`` (one value per band of q_j between ``edges_rad``: what no law explains).
    ``recording``: None for an error every recording shares; an index for one that holds only in
    that recording's rows (a periodic error whose phase is set anew at each power-up: its own
    coefficients per session, none for a session the fit has not seen)."""

    joint: int
    kind: str
    harmonic: float = 1.0
    edges_rad: tuple = ()
    label: str = ""
    recording: int | None = None

    def functions(self, q_joint: np.ndarray) -> np.ndarray:
        """F (n, k) at the joint's angles (n,)."""
        if self.kind == "harmonic":
            h = self.harmonic * np.asarray(q_joint, float)
            return np.stack([np.sin(h), np.cos(h)], axis=1)
        e = np.asarray(self.edges_rad, float)
        band = np.clip(np.searchsorted(e, q_joint, side="right") - 1, 0, len(e) - 2)
        F = np.zeros((len(q_joint), len(e) - 1))
        F[np.arange(len(q_joint)), band] = 1.0
        return F

    @property
    def names(self) -> tuple[str, ...]:
        """Parameter names of the term's coefficients (``angle_<label><joint>_...``)."""
        stem = f"angle_{self.label or self.kind}{self.joint}"
        if self.recording is not None:
            stem += f"_rec{self.recording + 1}"
        if self.kind == "harmonic":
            return (f"{stem}_sin", f"{stem}_cos")
        return tuple(f"{stem}_band{k + 1}" for k in range(len(self.edges_rad) - 1))


@dataclasses.dataclass
class PointState:
    """delta (5 N + 3,) kinematic errors and tool; comp: the compliances (rad / N m), first about
    the joints' axes then across them (tilt), then the angle terms' coefficients (rad); R (k, 3, 3),
    t (k, 3) mm each recording's
    base-to-instrument transform (y = R p + t)."""

    delta: np.ndarray
    comp: np.ndarray
    R: np.ndarray
    t: np.ndarray


class PointProblem:
    """Tool points measured in the instrument's frame.

    chain : the nominal arm (its ``tool_mm`` is the first guess of the tool point).
    q_rad : (n, N) encoder readings; xyz_mm : (n, 3) measured points.
    recording : (n,) int, which recording (own base frame) each row comes from; 0 if None.
    sigma_mm : (n, 3) the instrument's stated 1-sigma per value, or None (then one common
        sigma is estimated from the residuals).
    compliance_joints : joints (1-based) whose compliance under gravity is a parameter (needs
        the chain's masses); empty for a geometry-only model.
    tilt_joints : joints whose bearing tilts under the moment across their axis (rad / N m):
        everything the joint carries turns by c M_perp about the joint's origin.
    angle_terms : :class:`AngleTerm` s: joint-angle errors as functions of the joint's own
        angle (a discovery's transmission harmonics, an eccentricity, a table).
    prior : None, or the prior's scale: each kinematic error (not the tool, the frames or the
        compliances) gets a zero-mean Gaussian prior of ``prior`` times its typical size
        (:func:`parameter_scales`: 0.1 mm, 1 mrad), the tolerances of a machined arm. The solve
        is then the maximum a posteriori estimate: what the data cannot pin down (a narrow band
        of a joint, one sign of a torque) stays near the drawing instead of absorbing the
        recording's own structure, which is what carries a calibration to postures it has not
        seen. The std are posterior std.
    """

    def __init__(
        self,
        chain: Chain,
        q_rad: np.ndarray,
        xyz_mm: np.ndarray,
        recording: np.ndarray | None = None,
        sigma_mm: np.ndarray | None = None,
        compliance_joints=(),
        tilt_joints=(),
        prior: float | None = None,
        angle_terms=(),
    ):
        self.chain = chain
        self.q = np.asarray(q_rad, float)
        self.y = np.asarray(xyz_mm, float)
        n, N = self.q.shape
        self.rec = np.zeros(n, int) if recording is None else np.asarray(recording, int)
        self.n_rec = int(self.rec.max()) + 1
        self.sigma = None if sigma_mm is None else np.asarray(sigma_mm, float)
        self.extra_var = 0.0  # model-error variance (mm^2) added to every value: see reweight()
        self.cj = np.asarray(sorted(compliance_joints), int)
        self.tj = np.asarray(sorted(tilt_joints), int)
        self.compliance = len(self.cj) + len(self.tj) > 0
        if self.compliance and not chain.has_masses:
            raise ValueError("a compliance model needs the arm's masses")
        # gravity's moments at the readings, once: the links' sag is small enough that the
        # moments at the sagged posture differ by second-order amounts
        if self.compliance:
            M = gravity_moments(chain, self.q)
            w, _ = joint_axes(pose(chain, self.q))
            self.tau = np.einsum("nij,nij->ni", w, M)[:, self.cj - 1]
            Mt, wt = M[:, self.tj - 1], w[:, self.tj - 1]
            self.m_perp = Mt - np.einsum("nij,nij->ni", Mt, wt)[:, :, None] * wt
        else:
            self.tau, self.m_perp = np.zeros((n, 0)), np.zeros((n, 0, 3))
        if not (np.isfinite(self.q).all() and np.isfinite(self.y).all()):
            raise ValueError("point data must be finite")
        self.N = N
        self.nk = n_params(N)
        self.terms = tuple(angle_terms)
        self.F = self._term_functions(self.q, self.rec)
        self.na = sum(F.shape[1] for F in self.F)
        self.nc = len(self.cj) + len(self.tj) + self.na
        frame = ("rx", "ry", "rz", "x", "y", "z")
        suffix = [""] if self.n_rec == 1 else [f"_{r + 1}" for r in range(self.n_rec)]
        self.frame_names = tuple(f"base_{f}{s}" for s in suffix for f in frame)
        self.R_ref: np.ndarray | None = None
        self.prior = prior
        # tool components held at the drawing's value: ones the base frames already move the data
        # as (an arm whose axes are all parallel: the tool's and the base's height), see held_tool
        self.held: tuple[int, ...] = ()

    def held_tool(self, state=None, rel_tol: float = 1e-6) -> dict[str, str]:
        """Hold each tool component the base frames (and the other tool components) already move
        the data as: every axis parallel to one direction leaves the tool's offset along it and
        the base's indistinguishable. Sets :attr:`held` (left out of :attr:`always`); returns
        {name: why}."""
        import types

        self.held = ()
        s = self.start() if state is None else state
        names = self.names
        # the identifiable basis with the frames always kept and the tool as the one group
        frames = np.arange(len(names) - len(self.frame_names), len(names))
        view = types.SimpleNamespace(
            names=names,
            jacobian=self.jacobian,
            always=frames,
            groups=[np.arange(self.nk - 3, self.nk)],
        )
        dropped = identifiable_basis(view, s, rel_tol=rel_tol).dropped
        why = {n: f"{text}: held at the drawing's value" for n, text in dropped.items()}
        self.held = tuple(int(names.index(n)) for n in why)
        return why

    def _term_functions(self, q_rad: np.ndarray, rec: np.ndarray | None) -> list[np.ndarray]:
        """Each angle term's functions (n, k) at postures ``q_rad`` (n, N) of recordings ``rec``
        (n,) (None: a recording the fit has not seen, where per-recording terms are zero)."""
        out = []
        for t in self.terms:
            F = t.functions(q_rad[:, t.joint - 1])
            if t.recording is not None:
                F = F * (rec == t.recording)[:, None] if rec is not None else np.zeros_like(F)
            out.append(F)
        return out

    @property
    def names(self) -> tuple[str, ...]:
        """Parameter names, in the column order of :meth:`jacobian` and :meth:`values`."""
        return (
            param_names(self.N)
            + tuple(f"compliance{j}" for j in self.cj)
            + tuple(f"tilt_compliance{j}" for j in self.tj)
            + tuple(n for t in self.terms for n in t.names)
            + self.frame_names
        )

    @property
    def always(self) -> np.ndarray:
        """Columns always estimated: the base frames and the tool point (but its :attr:`held` components)."""
        nf = len(self.frame_names)
        tool = [k for k in range(self.nk - 3, self.nk) if k not in self.held]
        return np.r_[np.array(tool, int), np.arange(len(self.names) - nf, len(self.names))]

    @property
    def groups(self) -> list[np.ndarray]:
        """Column groups the identifiable basis is found in, in order: kinematics, Hayati's beta, compliance, angle
        terms."""
        N, nk = self.N, self.nk
        kin = np.array([5 * i + k for i in range(N) for k in range(4)])
        beta = np.array([5 * i + 4 for i in range(N)])
        out = [kin, beta]
        n_comp = len(self.cj) + len(self.tj)
        if n_comp:
            out.append(np.arange(nk, nk + n_comp))
        if self.na:
            out.append(np.arange(nk + n_comp, nk + self.nc))
        return out

    def weights(self) -> np.ndarray:
        """1 / sigma per value, (n, 3): the stated sigma and the model-error variance (one per
        recording: each setup its own)."""
        extra = np.asarray(self.extra_var, float)
        extra = extra[self.rec][:, None] if extra.ndim else extra
        var = (self.sigma**2 if self.sigma is not None else np.zeros_like(self.y)) + extra
        if not np.any(var > 0):
            return np.ones_like(self.y)  # nothing stated yet: unit weights until reweight()
        return 1.0 / np.sqrt(np.maximum(var, 1e-12))

    def start(self) -> PointState:
        """Nominal arm; each base frame from a rigid fit of its measured points to the nominal ones."""
        p = pose(self.chain, self.q).point
        R, t = np.empty((self.n_rec, 3, 3)), np.empty((self.n_rec, 3))
        for r in range(self.n_rec):
            m = self.rec == r
            if m.sum() < 3:
                raise ValueError(
                    f"recording {r + 1} has {m.sum()} rows: a base frame needs at least 3"
                )
            R[r], t[r] = rigid_transform(p[m], self.y[m])
        if self.R_ref is None:
            self.R_ref = R.copy()
        return PointState(np.zeros(self.nk), np.zeros(self.nc), R, t)

    def _q_eff(self, s: PointState, q=None, tau=None, F=None) -> np.ndarray:
        """The links' angles: the readings, sagged by compliance, less the angle terms' errors."""
        q, tau, F = (self.q, self.tau, self.F) if q is None else (q, tau, F)
        out = q.copy()
        if self.compliance and tau is not None and len(self.cj):
            out[:, self.cj - 1] += s.comp[: len(self.cj)] * tau
        k = len(self.cj) + len(self.tj)
        for t, Ft in zip(self.terms, F or ()):
            out[:, t.joint - 1] -= Ft @ s.comp[k : k + Ft.shape[1]]
            k += Ft.shape[1]
        return out

    def _tilt(self, s: PointState, P, m_perp) -> np.ndarray:
        """The tool point's shift from the bearings' tilt, (n, 3) mm, and its columns (n, 3, nt)."""
        _, o = joint_axes(P)
        cols = cross(m_perp, P.point[:, None] - o[:, self.tj - 1]).transpose(0, 2, 1)
        return cols @ s.comp[len(self.cj) : len(self.cj) + len(self.tj)], cols

    def base_points(
        self, s: PointState, q_rad: np.ndarray | None = None, session: int | None = None
    ) -> np.ndarray:
        """Modelled tool points in the arm's base frame, (n, 3) mm: this problem's postures, or
        others ``q_rad`` (m, N) (their gravity loads computed here) taken in recording
        ``session``'s session (None: one the fit has not seen, where per-recording angle terms
        are unknown and left out)."""
        if q_rad is None:
            q_eff, m_perp = self._q_eff(s), self.m_perp
        else:
            q_rad = np.atleast_2d(np.asarray(q_rad, float))
            tau, m_perp = None, None
            if self.compliance:
                other = PointProblem(
                    self.chain,
                    q_rad,
                    np.zeros((len(q_rad), 3)),
                    compliance_joints=self.cj,
                    tilt_joints=self.tj,
                )
                tau, m_perp = other.tau, other.m_perp
            F = self._term_functions(
                q_rad, None if session is None else np.full(len(q_rad), session)
            )
            q_eff = self._q_eff(s, q_rad, tau, F)
        P = pose(self.chain, q_eff, s.delta)
        return P.point + (self._tilt(s, P, m_perp)[0] if len(self.tj) else 0.0)

    def model(
        self,
        s: PointState,
        q_rad: np.ndarray | None = None,
        frame: int = 0,
        session: int | None = None,
    ) -> np.ndarray:
        """Modelled points (n, 3) in the instrument frame: this problem's rows (each in its own
        recording's frame), or postures ``q_rad`` (m, N) in recording ``frame``'s frame, with
        recording ``session``'s per-recording angle terms (None: another session's rows, e.g. a
        test recording in the same frame)."""
        p = self.base_points(s, q_rad, session)
        rec = self.rec if q_rad is None else np.full(len(p), frame)
        return np.einsum("nij,nj->ni", s.R[rec], p) + s.t[rec]

    def _prior_rows(self) -> tuple[np.ndarray, np.ndarray]:
        """Which parameters carry the prior, (k,) indices, and its sigma (k,)."""
        idx = np.arange(self.nk - 3)
        return idx, parameter_scales([self.names[i] for i in idx]) * self.prior

    def residuals(self, s: PointState) -> np.ndarray:
        """Whitened residuals (3 n,) of measured minus modelled points (and the prior's rows when there is one)."""
        r = ((self.y - self.model(s)) * self.weights()).ravel()
        if self.prior is None:
            return r
        idx, sig = self._prior_rows()
        return np.r_[r, s.delta[idx] / sig]

    def jacobian(self, s: PointState) -> np.ndarray:
        """Whitened d(residuals) / d(parameters), (3 n, len(names)); residual = y - model."""
        q_eff = self._q_eff(s)
        P = pose(self.chain, q_eff, s.delta)
        Jk = jacobian(self.chain, P=P)  # (n, 3, nk) base frame
        R = s.R[self.rec]
        n = len(self.q)
        cols = [np.einsum("nij,njk->nik", R, Jk)]
        p = P.point
        if len(self.cj):
            Jq = Jk[:, :, [theta_index(j) for j in self.cj]]
            cols.append(np.einsum("nij,njk->nik", R, Jq * self.tau[:, None, :]))
        if len(self.tj):
            shift, Jt = self._tilt(s, P, self.m_perp)
            cols.append(np.einsum("nij,njk->nik", R, Jt))
            p = p + shift
        for t, Ft in zip(self.terms, self.F):
            Jq = Jk[:, :, theta_index(t.joint)]  # (n, 3): the link turns by -Ft @ c
            cols.append(-np.einsum("nij,nj,nk->nik", R, Jq, Ft))
        Rp = np.einsum("nij,nj->ni", R, p)
        Jf = np.zeros((n, 3, 6 * self.n_rec))
        for r in range(self.n_rec):
            m = self.rec == r
            Jf[m, :, 6 * r : 6 * r + 3] = -skew(Rp[m])  # left perturbation of R
            Jf[m, :, 6 * r + 3 : 6 * r + 6] = np.eye(3)
        cols.append(Jf)
        J = (-np.concatenate(cols, axis=2) * self.weights()[:, :, None]).reshape(3 * n, -1)
        if self.prior is None:
            return J
        idx, sig = self._prior_rows()
        Jp = np.zeros((len(idx), J.shape[1]))
        Jp[np.arange(len(idx)), idx] = 1.0 / sig
        return np.r_[J, Jp]

    def update(self, s: PointState, step: np.ndarray) -> PointState:
        """The state moved by ``step`` (len(names),): additive for the errors, a left rotation for each base frame."""
        nk, nc = self.nk, self.nc
        f = step[nk + nc :].reshape(self.n_rec, 6)
        R = np.stack([rotvec_to_matrix(f[r, :3]) @ s.R[r] for r in range(self.n_rec)])
        comp = s.comp + step[nk : nk + nc] if nc else s.comp
        return PointState(s.delta + step[:nk], comp, R, s.t + f[:, 3:])

    def values(self, s: PointState) -> np.ndarray:
        """The state as one vector (len(names),): errors, compliances and terms, then each base frame's rotation
        (rotvec from the reference, rad) and translation (mm)."""
        w = np.stack([matrix_to_rotvec(s.R[r] @ self.R_ref[r].T) for r in range(self.n_rec)])
        frames = np.c_[w, s.t].ravel()
        return np.r_[s.delta, s.comp, frames]

    def reweight(self, s: PointState, dof: int) -> float:
        """Set the model-error variances, one per recording, so that each recording's whitened
        residuals have unit variance (variance components: what the stated sigma does not cover,
        and a setup that the model fits worse weighs less instead of having its tail called
        outliers). ``dof``: the fit's degrees of freedom, shared out by the recordings' sizes.
        Returns the model-error sigma (mm) over all rows."""
        e2 = (self.y - self.model(s)) ** 2
        base = self.sigma**2 if self.sigma is not None else np.zeros_like(e2)
        n_values = e2.size
        extra = np.zeros(self.n_rec)
        for r in range(self.n_rec):
            m = self.rec == r
            extra[r] = _variance_component(e2[m], base[m], max(dof * e2[m].size / n_values, 1.0))
        self.extra_var = extra
        return float(
            np.sqrt(np.sum(extra * np.bincount(self.rec, minlength=self.n_rec)) / len(self.rec))
        )


def _variance_component(e2: np.ndarray, base: np.ndarray, target: float) -> float:
    """v >= 0 with sum(e2 / (base + v)) = target (0 if the stated sigma already covers it)."""

    def chi2(v):
        return float(np.sum(e2 / np.maximum(base + v, 1e-12)))

    if chi2(0.0) <= target:
        return 0.0
    lo, hi = 0.0, float(np.mean(e2)) + 1e-12
    while chi2(hi) > target:
        hi *= 4
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if chi2(mid) > target else (lo, mid)
    return hi


# --- a tracker's spherical measurements ------------------------------------------------------------
@dataclasses.dataclass
class TrackerState:
    """delta (5 N + 3,); base2tracker R (3, 3), t (3,) mm."""

    delta: np.ndarray
    R: np.ndarray
    t: np.ndarray


class TrackerProblem:
    """A laser tracker's spherical readings (range, azimuth, elevation) of the tool point, with its own base frame; the
    seed's identification."""

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
        self._W = None  # per-posture whitening (n, 3, 3), made at the first start
        self._start = None  # the start's frame (R, t), found once
        self._G = None  # d(spherical)/d(encoders) at the start (n, 3, N), for the whitening
        self._last = None  # (delta, Pose) of the last evaluation
        self._last_jacobian = None  # (delta, R, t, J) of the last Jacobian
        # the tracker's rotation is reported as the small turn from this reference (the first
        # start's): the same coordinates its std is computed in. Share it between problems whose
        # estimates are compared.
        self.R_ref: np.ndarray | None = None
        if not (np.isfinite(self.q).all() and np.isfinite(measured).all()):
            raise ValueError("tracker data must be finite")

    @property
    def names(self) -> tuple[str, ...]:
        """Parameter names, in the column order of :meth:`jacobian`: the chain's errors, then the tracker frame."""
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
        """Residuals (3 n,) in spherical coordinates, whitened by each posture's covariance (instrument and encoders)."""
        if self._W is None:
            self.start()
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
        Js = self._W @ spherical_jacobian(y)
        Jy = np.empty((len(y), 3, self.nk + 6))
        Jy[:, :, : self.nk] = s.R @ jacobian(self.chain, P=P)
        Jy[:, :, self.nk : self.nk + 3] = -skew(P.point @ s.R.T)  # left perturbation of R
        Jy[:, :, self.nk + 3 :] = np.eye(3)
        return (Js @ Jy).reshape(len(y) * 3, -1)

    def update(self, s: TrackerState, step: np.ndarray) -> TrackerState:
        """The state moved by ``step``: additive for the errors, a left rotation for the tracker frame."""
        nk = self.nk
        return TrackerState(
            s.delta + step[:nk],
            rotvec_to_matrix(step[nk : nk + 3]) @ s.R,
            s.t + step[nk + 3 : nk + 6],
        )

    def values(self, s: TrackerState) -> np.ndarray:
        """The state as one vector (len(names),)."""
        return np.concatenate([s.delta, matrix_to_rotvec(s.R @ self.R_ref.T), s.t])


# --- cones and a length bar -----------------------------------------------------------------------
@dataclasses.dataclass
class ConeState:
    delta: np.ndarray
    cones: np.ndarray  # (2, 3) mm, base frame


class ConeProblem:
    """Tool points held in two kinematic cones and a length bar between them: the arm CMM's own artefacts, no external
    instrument."""

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


# --- identifiability and the solver ----------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class Basis:
    """Which columns are estimated (kept, indices into the problem's parameters) and which are
    dropped, each with why."""

    kept: np.ndarray
    dropped: dict[str, str]
    # how each dropped parameter moves the data as kept ones: {dropped: {kept: coefficient}},
    # in units of their typical sizes (parameter_scales), first order at the basis's state
    partners: dict[str, dict[str, float]] = dataclasses.field(default_factory=dict)


def _parallel_note(name: str, partners: list[str], parallel: list[tuple[int, int]]) -> str:
    """' (parallel axes i-j)' when a dropped d or theta depends on a neighbour across a parallel pair."""
    import re

    m = re.fullmatch(r"(dd|dtheta|da|dalpha)(\d+)", name)
    if not m:
        return ""
    j = int(m.group(2))
    for i, k in parallel:
        if j in (i, k) or j == k + 1:
            for p in partners:
                mp = re.fullmatch(r"(dd|dtheta|da|dalpha|dbeta)(\d+)", p)
                if mp and int(mp.group(2)) in (i, k, k + 1) and int(mp.group(2)) != j:
                    return f" (parallel axes {i}-{k})"
    return ""


def _pivoted_qr(a: np.ndarray, tol: float) -> tuple[np.ndarray, np.ndarray]:
    """Column-pivoted QR of ``a`` (m, n) cut at its practical rank: R's diagonal above ``tol``.

    LAPACK's geqp3 and orgqr called directly: scipy's ``qr`` checks, copies and forms the whole Q,
    three times the work on a trial's small matrix. Any m (few postures give fewer rows than a
    group has columns).

    Returns
    -------
    Q : (m, rank) orthonormal basis of the span of ``a``'s first ``rank`` pivoted columns
    pivots : (n,) column order, the first ``rank`` the independent ones
    """
    if a.shape[1] == 0:
        return np.empty((len(a), 0)), np.empty(0, int)
    # the blocked code's workspace (asked for): a tall Jacobian gains from it
    lwork = int(lapack.dgeqp3(a, lwork=-1)[3][0])
    qr, jpvt, tau, _, info = lapack.dgeqp3(a, lwork=max(lwork, 3 * a.shape[1] + 1))
    if info != 0:
        raise np.linalg.LinAlgError(f"geqp3 failed (info {info})")
    rank = int(np.sum(np.abs(np.diag(qr)) > tol))
    Q = lapack.dorgqr(qr[:, :rank], tau[:rank])[0] if rank else np.empty((len(a), 0))
    return Q, jpvt - 1


def _explained(Q: np.ndarray | None, K: np.ndarray, D: np.ndarray) -> np.ndarray:
    """Least-squares coefficients (k, d) of the columns D (m, d) on the kept columns K (m, k).

    ``Q`` (m, k): an orthonormal basis of K's span, K's columns independent; K = Q (Q^T K)
    exactly, so the k x k system Q^T K c = Q^T D is the least-squares problem at K's own
    condition. None when K's columns repeat each other: lstsq's minimum-norm answer (a solve
    there would not fail, it would return huge coefficients)."""
    if Q is None:
        return np.linalg.lstsq(K, D, rcond=None)[0]
    return np.linalg.solve(Q.T @ K, Q.T @ D)


def _grow_basis(Js: np.ndarray, always: np.ndarray, groups, skip: np.ndarray, tol: float):
    """Columns of ``Js`` (m, n) kept group by group, and an orthonormal basis of their span.

    ``always`` are kept whatever the data; each group's columns (but ``skip``'s) are pivoted on
    what the kept ones cannot explain, so a later group's column that repeats an earlier one is the
    one dropped. Returns kept (k,) and dropped (d,) column indices, in the order found, Q (m, r),
    and whether the always-kept columns are independent (then r = k)."""
    Q, piv = _pivoted_qr(Js[:, always], tol)
    always_independent = Q.shape[1] == len(
        always
    )  # else a degenerate set-up: they repeat each other
    kept, dropped = [always], []
    is_kept = np.zeros(Js.shape[1], bool)
    is_kept[always] = True
    for cols in groups:
        cols = np.asarray(cols, int)
        cols = cols[~is_kept[cols] & ~skip[cols]]
        if len(cols) == 0:
            continue
        rest = Js[:, cols] - Q @ (Q.T @ Js[:, cols])
        rest -= Q @ (
            Q.T @ rest
        )  # projected twice: a nearly dependent column keeps no trace of Q's span
        Qr, piv = _pivoted_qr(rest, tol)
        rank = Qr.shape[1]
        kept.append(cols[piv[:rank]])
        is_kept[cols[piv[:rank]]] = True
        dropped.append(cols[piv[rank:]])
        Q = np.hstack([Q, Qr])  # rest is orthogonal to Q, so its own basis extends Q's
    return (
        np.concatenate(kept),
        np.concatenate(dropped or [np.empty(0, int)]),
        Q,
        always_independent,
    )


def identifiable_basis(
    problem, state=None, rel_tol: float = 1e-4, parallel: list | None = None, explain: bool = True
) -> Basis:
    """Practical rank of the scaled, whitened Jacobian, group by group: ``problem.always`` (kept
    whatever the data), then each of ``problem.groups`` pivoted (QR) on what the kept columns
    cannot explain, so a later group's column that repeats an earlier one is the one dropped.

    Parameters
    ----------
    problem : a problem (``names``, ``always``, ``groups``, ``start()``, ``jacobian(state)``)
    state : the state to linearise at (default ``problem.start()``)
    rel_tol : float
        Relative to the largest column: a dependence that holds only up to the data's own scatter
        is a dependence.
    parallel : list of (i, j), optional
        Consecutive parallel joint pairs, for the reasons.
    explain : bool
        False: the kept columns alone (no reasons, no partners), to compare two bases.

    Returns
    -------
    Basis : kept (k,) sorted column indices; dropped in column order, each with what it moves the
    data as (partners in units of the parameters' typical sizes)
    """
    s = problem.start() if state is None else state
    names = problem.names
    # each column as the data move under a typical-size error of its parameter
    Js = problem.jacobian(s) * parameter_scales(names)
    if not np.isfinite(Js).all():  # geqp3 would return a basis of garbage
        raise np.linalg.LinAlgError("the Jacobian is not finite")
    norm = np.linalg.norm(Js, axis=0)
    # The tolerance's reference is the largest column of a geometric error: a compliance's column
    # grows with the arm's torques (a 200 kg arm's, 25 times an angle's), and would otherwise lift
    # the tolerance over columns of the geometry that the data do determine.
    geometric = np.array([not n.startswith(("compliance", "tilt_compliance")) for n in names])
    top = norm[geometric].max(initial=0.0) if geometric.any() else norm.max(initial=0.0)
    zero = norm < 1e-9 * max(top, 1e-300)
    kept, dropped, Q, always_independent = _grow_basis(
        Js, np.asarray(problem.always, int), problem.groups, zero, rel_tol * top
    )
    kept, dropped = np.sort(kept), np.sort(dropped)  # kept in Q's order for the partners below
    if not explain:
        return Basis(kept=kept, dropped={names[j]: "" for j in dropped})
    reasons = {
        names[j]: "does not move the data at all"
        for j in np.flatnonzero(zero)
        if j not in kept and any(j in g for g in problem.groups)
    }
    if len(dropped) == 0:
        return Basis(kept=kept, dropped=reasons)
    coefs = _explained(Q if always_independent else None, Js[:, kept], Js[:, dropped])
    kept_names = [names[k] for k in kept]
    partners = {}
    largest3 = np.argsort(-np.abs(coefs), axis=0)[
        :3
    ].T.tolist()  # each dropped column's largest partners
    for j, coef, order in zip(dropped.tolist(), coefs.T.tolist(), largest3):
        big = [(kept_names[k], coef[k]) for k in order if abs(coef[k]) > 0.05 * abs(coef[order[0]])]
        text = "moves the data as " + " + ".join(f"{n} ({c:+.2f})" for n, c in big)
        reasons[names[j]] = text + _parallel_note(names[j], [n for n, _ in big], parallel or [])
        partners[names[j]] = dict(zip(kept_names, coef))
    return Basis(kept=kept, dropped=reasons, partners=partners)


@dataclasses.dataclass(frozen=True)
class Identification:
    state: object
    estimate: dict[str, float]  # kept parameters by name
    std: dict[str, float]
    basis: Basis
    rms: float  # whitened residual RMS (1 when the noise model is right)
    iterations: int
    converged: bool = True
    cov: np.ndarray | None = None  # of the kept parameters, in basis.kept order


# a sum of squares of a few hundred whitened residuals is exact to about 1e-14 of itself: a
# promised decrease below this fraction of the cost is rounding (a step of ~1e-6 std)
COST_ROUNDING = 1e-13
# kept columns whose variance inflation reaches this repeat each other (see identify)
MAX_VARIANCE_INFLATION = 1e12


def identify(
    problem, basis: Basis, state=None, max_iter: int = 50, xtol: float = 1e-8
) -> Identification:
    """Levenberg-Marquardt over the kept parameters; std from the whitened normal matrix.

    Converged when the last accepted step moved no parameter by more than ``xtol`` of its std, or
    when even the undamped step would lower the cost by less than the cost's own rounding (then
    no comparison of costs can tell a better state from a worse one: the minimum, to the precision
    the data are summed in). When no step, however damped, lowers the cost, the solve is converged
    only if the gradient vanishes; one that ran out of iterations says so in ``converged``."""
    s = problem.start() if state is None else state
    k = basis.kept
    lam = 1e-3
    r = problem.residuals(s)
    cost = r @ r
    it, converged = 0, False
    for it in range(1, max_iter + 1):  # noqa: B007 - the count is reported after the loop
        J = problem.jacobian(s)[:, k]
        A, g = J.T @ J, J.T @ r
        # the most the linearised model promises is the undamped step's decrease, g' A^-1 g: a
        # damped step promises less, so only the undamped one may say the minimum is reached
        try:
            floor = bool(g @ np.linalg.solve(A, g) <= COST_ROUNDING * cost)
        except np.linalg.LinAlgError:
            floor = False
        if floor:
            converged = True
            break
        accepted = False
        while True:
            step_k = -np.linalg.solve(A + lam * np.diag(np.diag(A)), g)
            step = np.zeros(len(problem.names))
            step[k] = step_k
            s_new = problem.update(s, step)
            r_new = problem.residuals(s_new)
            if r_new @ r_new < cost:
                s, r, cost, lam = s_new, r_new, r_new @ r_new, max(lam / 10, 1e-12)
                accepted = True
                break
            if np.max(np.abs(step_k) * np.sqrt(np.diag(A))) < xtol:
                break  # a step already below the tolerance: shorter ones change nothing either
            lam *= 10
            if lam > 1e12:
                break
        if accepted:
            if np.max(np.abs(step_k) * np.sqrt(np.diag(A))) < xtol:
                converged = True
                break
            continue
        # no step lowers the cost any more (the damped ones, however short): a minimum only if the
        # gradient says so too; a wrong model or Jacobian ends here unconverged
        converged = bool(
            np.max(np.abs(g) / np.sqrt(np.maximum(np.diag(A), 1e-300)))
            < 1e-6 * max(np.sqrt(cost), 1.0)
        )
        break
    J = problem.jacobian(s)[:, k]
    dof = max(len(r) - len(k), 1)
    s2 = cost / dof
    A = J.T @ J
    try:
        A_inv = np.linalg.inv(A)
    except np.linalg.LinAlgError:
        A_inv = np.full_like(A, np.nan)  # exactly singular: said below, as every other kind is
    # Each kept column's variance inflation, (A^-1)_ii A_ii: 1 alone, 1 / (1 - R^2) beside columns
    # that explain it by R^2. The basis keeps none beyond about 1e8; columns that repeat each
    # other to rounding (frames and a tool a degenerate arm cannot tell apart) give about 1 / eps,
    # or a negative variance, or a NaN, whichever the rounding picks: all of them are singular.
    vif = np.diag(A_inv) * np.diag(A)
    if not np.all((vif >= 0.5) & (vif < MAX_VARIANCE_INFLATION)):
        raise np.linalg.LinAlgError(
            "the kept parameters' normal matrix is singular to working precision"
        )
    cov = A_inv * s2
    names = problem.names
    values = problem.values(s)
    return Identification(
        state=s,
        estimate={names[j]: float(values[j]) for j in k},
        std={names[j]: float(np.sqrt(cov[i, i])) for i, j in enumerate(k)},
        basis=basis,
        rms=float(np.sqrt(s2)),
        iterations=it,
        converged=converged,
        cov=cov,
    )


def identify_identifiable(problem, parallel: list | None = None) -> Identification:
    """Basis at the start, solve, then the basis again at the solution: a dependence that only
    holds once the model fits (e.g. all points of one cone coinciding) shows there; if the basis
    changes, solve again with it."""
    basis = identifiable_basis(problem, parallel=parallel)
    first = identify(problem, basis)
    again = identifiable_basis(problem, first.state, parallel=parallel, explain=False)
    if set(again.kept) == set(basis.kept):
        return first
    again = identifiable_basis(problem, first.state, parallel=parallel)
    # restart from the solution with the newly dropped parameters back at nominal (kept fixed
    # there), so the fit is re-expressed in the new basis rather than carried over
    reset = np.zeros(len(problem.names))
    newly = np.setdiff1d(basis.kept, again.kept)
    reset[newly] = -problem.values(first.state)[newly]
    return identify(problem, again, state=problem.update(first.state, reset))


def parameter_scales(names) -> np.ndarray:
    """Typical sizes to make columns comparable: 0.1 mm for lengths, 1 mrad for angles, 100 urad
    for a joint's angle error terms,
    10 urad / N m for a joint's compliance (a robot's gearbox: 1e5 N m / rad), 1 urad / N m for a
    bearing's tilt."""
    return np.array(_scales(tuple(names)))


@functools.lru_cache(maxsize=64)
def _scales(names: tuple) -> tuple:
    """The typical sizes of ``names``' errors, cached: a problem asks at every basis and bound."""
    return tuple(
        1e-3
        if n.startswith(("dalpha", "dtheta", "dbeta", "tracker_r", "base_r", "cone_r"))
        else 1e-4
        if n.startswith("angle_")
        else 1e-5
        if n.startswith("compliance")
        else 1e-6
        if n.startswith("tilt_compliance")
        else 0.1
        for n in names
    )


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    """np.array_equal for two float arrays, without its conversions (a cache's test, called at every
    residual and Jacobian)."""
    return a.shape == b.shape and bool((a == b).all())


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
