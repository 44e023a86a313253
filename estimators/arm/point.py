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
encoder reading (:func:`calibench.estimators.arm.kinematics.gravity_torques`).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from calibench.estimators.arm.bending import flex_columns, tilt_columns
from calibench.estimators.arm.kinematics import (
    ArmParameters,
    Chain,
    Pose,
    chain_names,
    flex_moments,
    gravity_moments,
    in_readings,
    jacobian,
    joint_axes,
    n_params,
    parameter_scales,
    pose,
    theta_index,
)
from calibench.estimators.arm.terms import directions
from calibench.estimators.identification.basis import identifiable_basis
from calibench.estimators.identification.covariance import variance_component
from calibench.estimators.identification.problem import Regrouped
from calibench.estimators.rotations import matrix_to_rotvec, rigid_transform, rotvec_to_matrix, skew


# --- points in the instrument's frame ------------------------------------------------------------
@dataclasses.dataclass
class PointState:
    """delta (5 N + 3 T,) kinematic errors and tools; comp: the compliances (rad / N m), first
    about the joints' axes, across them (tilt), across the links (flex), the cables', then the
    angle terms' coefficients (rad); R (k, 3, 3),
    t (k, 3) mm each recording's
    base-to-instrument transform (y = R p + t)."""

    delta: np.ndarray
    comp: np.ndarray
    R: np.ndarray
    t: np.ndarray


class PointProblem(ArmParameters):
    """Tool points measured in the instrument's frame.

    chain : the nominal arm, serial or branched (its tools' offsets are the first guess of the
        tool points).
    q_rad : (n, N) encoder readings (a follower's column ignored); xyz_mm : (n, 3) measured
        points, each row's of its ``tool``.
    recording : (n,) int, which recording (own base frame) each row comes from; 0 if None.
    sigma_mm : (n, 3) the instrument's stated 1-sigma per value, or None (then one common
        sigma is estimated from the residuals).
    compliance_joints : joints (1-based) whose compliance under gravity is a parameter (needs
        the chain's masses); empty for a geometry-only model.
    tilt_joints : joints whose bearing tilts under the moment across their axis (rad / N m):
        everything the joint carries turns by c M_perp about the joint's origin.
    flex_links : joints whose link bends across itself (rad / N m): everything beyond the
        link's middle turns by c M_perp about the middle, M_perp the moment there of the weight
        it carries beyond its own, across the link (:func:`flex_moments`).
    tool : (n,) int, each row's tool (0-based; a branched arm's several measured points), or
        None: every row the first.
    cable_motors : motors (1-based) of an arm with a transmission (``chain.coupling``) whose
        cable stretches (rad / N m at the motor): the joints' gravity torques carried back to the
        motor (coupling column . tau) stretch it, and the stretch turns the joints it drives
        (the coupling column times it).
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
        cable_motors=(),
        dirs: np.ndarray | None = None,
        flex_links=(),
        tool: np.ndarray | None = None,
    ):
        self.chain = chain
        self.q = np.asarray(q_rad, float)
        self.y = np.asarray(xyz_mm, float)
        n, N = self.q.shape
        self.rec = np.zeros(n, int) if recording is None else np.asarray(recording, int)
        self.n_rec = int(self.rec.max()) + 1
        self.sigma = None if sigma_mm is None else np.asarray(sigma_mm, float)
        # model-error variance (mm^2) added to every value, one per recording after reweight()
        self.extra_var: float | np.ndarray = 0.0
        self.cj = np.asarray(sorted(compliance_joints), int)
        self.tj = np.asarray(sorted(tilt_joints), int)
        self.cm = np.asarray(sorted(cable_motors), int)
        self.fl = np.asarray(sorted(flex_links), int)
        self.tool = None if tool is None else np.asarray(tool, int)
        coupling = np.eye(N) if chain.coupling is None else np.asarray(chain.coupling, float)
        self.cable_cols = coupling[:, self.cm - 1]  # (N, k): what a motor's stretch does to q
        self.compliance = len(self.cj) + len(self.tj) + len(self.fl) + len(self.cm) > 0
        if self.compliance and not chain.has_masses:
            raise ValueError("a compliance model needs the arm's masses")
        # gravity's moments at the readings, once: the links' sag is small enough that the
        # moments at the sagged posture differ by second-order amounts
        if self.compliance:
            P0 = pose(chain, self.q, tool=self.tool)
            M = gravity_moments(chain, P=P0)
            w, _ = joint_axes(P0)
            # on the readings: a follower's load is carried by the joints it follows
            tau = in_readings(chain, np.einsum("nij,nij->ni", w, M))
            self.tau = tau[:, self.cj - 1]
            self.tau_motor = tau @ self.cable_cols
            Mt, wt = M[:, self.tj - 1], w[:, self.tj - 1]
            self.m_perp = Mt - np.einsum("nij,nij->ni", Mt, wt)[:, :, None] * wt
            self.m_flex = flex_moments(chain, P0, self.fl) if len(self.fl) else np.zeros((n, 0, 3))
        else:
            self.tau, self.m_perp = np.zeros((n, 0)), np.zeros((n, 0, 3))
            self.tau_motor, self.m_flex = np.zeros((n, 0)), np.zeros((n, 0, 3))
        if not (np.isfinite(self.q).all() and np.isfinite(self.y).all()):
            raise ValueError("point data must be finite")
        self.N = N
        self.nk = n_params(N, chain.n_tools)
        self.terms = tuple(angle_terms)
        self.coupling = coupling
        # each drive's direction of last motion, for the direction terms (lost motion, a cable's
        # friction): the caller's, taken over every row of its recordings in their order
        self.dirs = dirs if dirs is not None else self._directions(self.q, self.rec)
        self.F = self._term_functions(self.q, self.rec, self.dirs)
        self.na = sum(F.shape[1] for F in self.F)
        self.n_phys = len(self.cj) + len(self.tj) + len(self.fl) + len(self.cm)
        self.nc = self.n_phys + self.na
        frame = ("rx", "ry", "rz", "x", "y", "z")
        suffix = [""] if self.n_rec == 1 else [f"_{r + 1}" for r in range(self.n_rec)]
        self.frame_names = tuple(f"base_{f}{s}" for s in suffix for f in frame)
        self.R_ref: np.ndarray | None = None
        self.prior = prior
        # tool components held at the drawing's value: ones the base frames already move the data
        # as (an arm whose axes are all parallel: the tool's and the base's height), see held_tool
        self.held: tuple[int, ...] = ()
        # the last state's chain at the rows (delta, comp, Pose): a solver's residuals at the
        # state it accepts and its next Jacobian share one forward kinematics (see _pose)
        self._pose_at: tuple[np.ndarray, np.ndarray, Pose] | None = None

    def _pose(self, s: PointState) -> Pose:
        """The chain at state ``s`` (its errors and compliances; not its frames) on this
        problem's rows, the last one kept: a solver's residuals at a state and its Jacobian
        there evaluate it once."""
        at = self._pose_at
        if at is not None and np.array_equal(at[0], s.delta) and np.array_equal(at[1], s.comp):
            return at[2]
        P = pose(self.chain, self._q_eff(s), s.delta, self.tool)
        self._pose_at = (s.delta.copy(), s.comp.copy(), P)
        return P

    def held_tool(self, state=None, rel_tol: float = 1e-6) -> dict[str, str]:
        """Hold each tool component the base frames (and the other tool components) already move
        the data as: every axis parallel to one direction leaves the tool's offset along it and
        the base's indistinguishable. Sets :attr:`held` (left out of :attr:`always`); returns
        {name: why}."""
        self.held = ()
        s = self.start() if state is None else state
        names = self.names
        # the identifiable basis with the frames always kept and the tool as the one group
        frames = np.arange(len(names) - len(self.frame_names), len(names))
        view = Regrouped(self, always=frames, groups=[np.arange(5 * self.N, self.nk)])
        dropped = identifiable_basis(view, s, rel_tol=rel_tol).dropped
        why = {n: f"{text}: held at the drawing's value" for n, text in dropped.items()}
        self.held = tuple(int(names.index(n)) for n in why)
        return why

    def _directions(self, q_rad: np.ndarray, rec: np.ndarray | None) -> np.ndarray | None:
        """The joints' and motors' directions of last motion (n, 2 N) over rows ``q_rad`` in
        their order, where a term needs them (None otherwise)."""
        if not any(t.kind == "direction" for t in self.terms):
            return None
        return directions(q_rad, rec, None if self.chain.coupling is None else self.coupling)

    def _term_functions(
        self, q_rad: np.ndarray, rec: np.ndarray | None, dirs: np.ndarray | None
    ) -> list[np.ndarray]:
        """Each angle term's functions (n, k) at postures ``q_rad`` (n, N) of recordings ``rec``
        (n,) (None: a recording the fit has not seen, where per-recording terms are zero), its
        drives' directions ``dirs`` (n, 2 N) (joints', then motors')."""
        out = []
        for t in self.terms:
            d = None
            if t.kind == "direction" and dirs is not None:
                d = dirs[:, (self.N if t.column else 0) + t.joint - 1]
            F = t.functions(q_rad[:, t.joint - 1], d)
            if t.recording is not None:
                F = F * (rec == t.recording)[:, None] if rec is not None else np.zeros_like(F)
            out.append(F)
        return out

    @property
    def names(self) -> tuple[str, ...]:
        """Parameter names, in the column order of :meth:`jacobian` and :meth:`values`."""
        return (
            chain_names(self.chain)
            + tuple(f"compliance{j}" for j in self.cj)
            + tuple(f"tilt_compliance{j}" for j in self.tj)
            + tuple(f"flex_compliance{j}" for j in self.fl)
            + tuple(f"cable_compliance{m}" for m in self.cm)
            + tuple(n for t in self.terms for n in t.names)
            + self.frame_names
        )

    @property
    def always(self) -> np.ndarray:
        """Columns always estimated: the base frames and the tool points (but their
        :attr:`held` components)."""
        nf = len(self.frame_names)
        tool = [k for k in range(5 * self.N, self.nk) if k not in self.held]
        return np.r_[np.array(tool, int), np.arange(len(self.names) - nf, len(self.names))]

    @property
    def groups(self) -> list[np.ndarray]:
        """Column groups the identifiable basis is found in, in order: kinematics, Hayati's
        beta, compliance, angle terms."""
        N, nk = self.N, self.nk
        kin = np.array([5 * i + k for i in range(N) for k in range(4)])
        beta = np.array([5 * i + 4 for i in range(N)])
        out = [kin, beta]
        n_comp = self.n_phys
        if n_comp:
            out.append(np.arange(nk, nk + n_comp))
        if self.na:
            out.append(np.arange(nk + n_comp, nk + self.nc))
        return out

    def scales(self) -> np.ndarray:
        """(n,) typical sizes of the parameters' errors (:func:`parameter_scales`), a cable's
        compliance at its motor divided by its coupling column's squared norm: a motor's angle in
        any unit (its column scaled by 1 / s, its compliance by s^2) then gives the same scaled
        column, so what is dropped never depends on the unit the transmission is written in."""
        out = parameter_scales(self.names)
        if len(self.cm):
            k = self.nk + len(self.cj) + len(self.tj) + len(self.fl)
            out = out.copy()
            out[k : k + len(self.cm)] /= np.maximum(np.sum(self.cable_cols**2, axis=0), 1e-300)
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
        """Nominal arm; each base frame from a rigid fit of its measured points to the
        nominal ones."""
        p = pose(self.chain, self.q, tool=self.tool).point
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

    def _q_eff(self, s: PointState, q=None, tau=None, F=None, tau_motor=None) -> np.ndarray:
        """The links' angles: the readings, sagged by compliance, less the angle terms' errors."""
        if q is None:
            q, tau, F, tau_motor = self.q, self.tau, self.F, self.tau_motor
        out = q.copy()
        if self.compliance and tau is not None and len(self.cj):
            out[:, self.cj - 1] += s.comp[: len(self.cj)] * tau
        k = len(self.cj) + len(self.tj) + len(self.fl)
        if len(self.cm) and tau_motor is not None:
            out += (tau_motor * s.comp[k : k + len(self.cm)]) @ self.cable_cols.T
        k += len(self.cm)
        for t, Ft in zip(self.terms, F or ()):
            err = Ft @ s.comp[k : k + Ft.shape[1]]
            if t.column:  # a motor's: every joint it drives
                out -= err[:, None] * np.asarray(t.column, float)
            else:
                out[:, t.joint - 1] -= err
            k += Ft.shape[1]
        return out

    def _tilt(self, s: PointState, P, m_perp) -> tuple[np.ndarray, np.ndarray]:
        """The tool point's shift from the bearings' tilt, (n, 3) mm, and its columns (n, 3, nt)."""
        cols = tilt_columns(self.chain, P, self.tj, m_perp)
        return cols @ s.comp[len(self.cj) : len(self.cj) + len(self.tj)], cols

    def _flex(self, s: PointState, P, m_flex) -> tuple[np.ndarray, np.ndarray]:
        """The tool point's shift from the links' lateral flex, (n, 3) mm, and its columns
        (n, 3, nf)."""
        cols = flex_columns(self.chain, P, self.fl, m_flex)
        k = len(self.cj) + len(self.tj)
        return cols @ s.comp[k : k + len(self.fl)], cols

    def _turns(self, Jk: np.ndarray, joints) -> np.ndarray:
        """How each of ``joints`` (1-based) readings turns the points, (n, 3, k): its joint's
        Jacobian column and, where joints follow it, theirs by its share."""
        if not self.chain.followers:
            return Jk[:, :, [theta_index(j) for j in joints]]
        every = Jk[:, :, [theta_index(j) for j in range(1, self.N + 1)]]
        return in_readings(self.chain, every)[:, :, np.asarray(joints, int) - 1]

    def base_points(
        self,
        s: PointState,
        q_rad: np.ndarray | None = None,
        session: int | None = None,
        tool: np.ndarray | None = None,
    ) -> np.ndarray:
        """Modelled tool points in the arm's base frame, (n, 3) mm: this problem's postures, or
        others ``q_rad`` (m, N) (their gravity loads computed here) of tools ``tool`` (m,)
        (0-based; None: the first) taken in recording ``session``'s session (None: one the fit
        has not seen, where per-recording angle terms are unknown and left out)."""
        if q_rad is None:
            P, m_perp, m_flex = self._pose(s), self.m_perp, self.m_flex
        else:
            q_rad = np.atleast_2d(np.asarray(q_rad, float))
            tau, m_perp, tau_motor, m_flex = None, None, None, None
            if self.compliance:
                other = PointProblem(
                    self.chain,
                    q_rad,
                    np.zeros((len(q_rad), 3)),
                    compliance_joints=self.cj,
                    tilt_joints=self.tj,
                    cable_motors=self.cm,
                    flex_links=self.fl,
                    tool=tool,
                )
                tau, m_perp, tau_motor = other.tau, other.m_perp, other.tau_motor
                m_flex = other.m_flex
            rec = None if session is None else np.full(len(q_rad), session)
            F = self._term_functions(q_rad, rec, self._directions(q_rad, None))
            q_eff = self._q_eff(s, q_rad, tau, F, tau_motor)
            P = pose(self.chain, q_eff, s.delta, tool)
        shift = self._tilt(s, P, m_perp)[0] if len(self.tj) else 0.0
        if len(self.fl):
            shift = shift + self._flex(s, P, m_flex)[0]
        return P.point + shift

    def model(
        self,
        s: PointState,
        q_rad: np.ndarray | None = None,
        frame: int = 0,
        session: int | None = None,
        tool: np.ndarray | None = None,
    ) -> np.ndarray:
        """Modelled points (n, 3) in the instrument frame: this problem's rows (each in its own
        recording's frame), or postures ``q_rad`` (m, N) of tools ``tool`` (m,) (0-based; None:
        the first) in recording ``frame``'s frame, with recording ``session``'s per-recording
        angle terms (None: another session's rows, e.g. a test recording in the same frame)."""
        p = self.base_points(s, q_rad, session, tool)
        rec = self.rec if q_rad is None else np.full(len(p), frame)
        return np.einsum("nij,nj->ni", s.R[rec], p) + s.t[rec]

    def _prior_rows(self) -> tuple[np.ndarray, np.ndarray]:
        """Which parameters carry the prior, (k,) indices, and its sigma (k,)."""
        idx, names = np.arange(5 * self.N), self.names  # names: a tuple made at each call
        return idx, parameter_scales([names[i] for i in idx]) * self.prior

    def residuals(self, s: PointState) -> np.ndarray:
        """Whitened residuals (3 n,) of measured minus modelled points (and the prior's rows
        when there is one)."""
        r = ((self.y - self.model(s)) * self.weights()).ravel()
        if self.prior is None:
            return r
        idx, sig = self._prior_rows()
        return np.r_[r, s.delta[idx] / sig]

    def jacobian(self, s: PointState) -> np.ndarray:
        """Whitened d(residuals) / d(parameters), (3 n, len(names)); residual = y - model.
        Each block of columns is written into the one output in place (no stacked copies)."""
        P = self._pose(s)
        Jk = jacobian(self.chain, P=P)  # (n, 3, nk) base frame
        R = s.R[self.rec]
        n = len(self.q)
        n_prior = 0 if self.prior is None else len(self._prior_rows()[0])
        out = np.empty((3 * n + n_prior, len(self.names)))
        J = out[: 3 * n].reshape(n, 3, -1)  # a view: the rows' block
        blocks, p = [Jk], P.point  # base-frame columns, in the names' order
        if len(self.cj):
            blocks.append(self._turns(Jk, self.cj) * self.tau[:, None, :])
        for on, bend, m in ((self.tj, self._tilt, self.m_perp), (self.fl, self._flex, self.m_flex)):
            if len(on):
                shift, Jt = bend(s, P, m)
                blocks.append(Jt)
                p = p + shift
        if len(self.cm):
            Jq = self._turns(Jk, range(1, self.N + 1))  # (n, 3, N)
            blocks.append(np.einsum("nij,jk,nk->nik", Jq, self.cable_cols, self.tau_motor))
        k = 0  # each block turned into its rows' frames, in place
        for B in blocks:
            np.einsum("nij,njk->nik", R, B, out=J[:, :, k : k + B.shape[2]])
            k += B.shape[2]
        for t, Ft in zip(self.terms, self.F):
            if t.column:  # (n, 3): a motor's error turns the joints along its column
                Jq = self._turns(Jk, range(1, self.N + 1)) @ np.asarray(t.column, float)
            else:
                Jq = self._turns(Jk, [t.joint])[:, :, 0]  # (n, 3): the link turns by -Ft @ c
            J[:, :, k : k + Ft.shape[1]] = -np.einsum("nij,nj,nk->nik", R, Jq, Ft)
            k += Ft.shape[1]
        turn = -skew(np.einsum("nij,nj->ni", R, p))  # left perturbation of R, (n, 3, 3)
        for r in range(self.n_rec):  # each frame's columns, zero off its recording's rows
            m = (self.rec == r)[:, None, None]
            J[:, :, k + 6 * r : k + 6 * r + 3] = np.where(m, turn, 0.0)
            J[:, :, k + 6 * r + 3 : k + 6 * r + 6] = np.where(m, np.eye(3), 0.0)
        np.multiply(J, -self.weights()[:, :, None], out=J)  # residual = y - model: negated
        if self.prior is None:
            return out
        idx, sig = self._prior_rows()
        Jp = out[3 * n :]
        Jp[:] = 0.0
        Jp[np.arange(len(idx)), idx] = 1.0 / sig
        return out

    def update(self, s: PointState, step: np.ndarray) -> PointState:
        """The state moved by ``step`` (len(names),): additive for the errors, a left
        rotation for each base frame."""
        nk, nc = self.nk, self.nc
        f = step[nk + nc :].reshape(self.n_rec, 6)
        R = np.stack([rotvec_to_matrix(f[r, :3]) @ s.R[r] for r in range(self.n_rec)])
        comp = s.comp + step[nk : nk + nc] if nc else s.comp
        return PointState(s.delta + step[:nk], comp, R, s.t + f[:, 3:])

    def values(self, s: PointState) -> np.ndarray:
        """The state as one vector (len(names),): errors, compliances and terms, then each
        base frame's rotation (rotvec from the reference, rad) and translation (mm)."""
        assert self.R_ref is not None, "values are reported after a start"
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
            extra[r] = variance_component(e2[m], base[m], max(dof * e2[m].size / n_values, 1.0))
        self.extra_var = extra
        return float(
            np.sqrt(np.sum(extra * np.bincount(self.rec, minlength=self.n_rec)) / len(self.rec))
        )
