"""The joint adjustment of a Stewart platform's calibration: maximum likelihood over the
tracker's stations, every pose and the six legs together, from every length and reading.

Lengths in mm; a pose is (R (3, 3), t (3,)) mapping platform-frame points into the base frame.
:class:`JointProblem` is an identification problem
(:class:`~calibench.estimators.identification.problem.Problem`) solved by the one solver,
:func:`~calibench.estimators.identification.solver.identify`; its Jacobian is sparse (each
pose's rows touch only its own six columns, the stations' and the legs'), so the solver
factorises its normal equations sparsely instead of eliminating the poses by hand.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy import sparse

from calibench.estimators.identification.basis import Basis
from calibench.estimators.identification.normal import inverse_normal
from calibench.estimators.identification.solver import identify
from calibench.estimators.rotations import matrix_to_rotvec, rotvecs_to_matrices
from calibench.estimators.stewart.kinematics import leg_derivatives

LEG_PARAMS = ("a", "b", "c", "m", "n", "q", "l")  # r (a, b, c), B (m, n, q), l: one leg's seven
POSE_PARAMS = ("wx", "wy", "wz", "x", "y", "z")  # a pose's left rotation (rad), its shift (mm)
N_STATIONS = 9  # three stations' x, y, z
N_LEGS = 6 * len(LEG_PARAMS)
# Every residual is a difference of lengths of a metre or two measured to a few tenths of a
# micrometre: its rounding is ~1e-9 of its sigma, and the cost is exact only to ~1e-10 of itself
# (not the 1e-13 of a sum of unit-size terms). Comparisons of costs take the solve to ~1e-4 std;
# Gauss-Newton's steps, which compare no costs, take it the rest of the way (``finish``).
JOINT_COST_ROUNDING = 1e-9
# The step tolerance (in units of each parameter's std): the Gauss-Newton steps' own rounding is
# 2e-8 to 1e-7 of the std here, so 1e-8 is never met; a step below 1e-6 leaves, by Gauss-Newton's
# quadratic convergence, an error at that rounding (the old hand-written solver's minimum to
# 1e-12 mm). Within ~1e-3 std of the minimum the steps compare no costs (JOINT_COST_ROUNDING).
JOINT_XTOL = 1e-6
# The first damping: the start (the sequential pipeline's estimate) is a consistent estimate a
# few std from the joint one, where Gauss-Newton's steps are already good.
JOINT_DAMPING = 1e-9


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
class JointState:
    """The joint problem's state: stations (3, 3), poses R (n, 3, 3), t (n, 3), platform hinges
    r (6, 3), base hinges B (6, 3), initial lengths l (6,), all mm."""

    stations: np.ndarray
    R: np.ndarray
    t: np.ndarray
    r: np.ndarray
    B: np.ndarray
    l: np.ndarray


def _csr_order(rows: np.ndarray, cols: np.ndarray, shape: tuple[int, int]):
    """The CSR layout of entries at (rows, cols) (nnz,), distinct: the permutation (nnz,) that
    puts data given in this order into CSR order, and CSR's indices and indptr."""
    P = sparse.csr_matrix((np.arange(1.0, len(rows) + 1), (rows, cols)), shape=shape)
    return P.data.astype(int) - 1, P.indices, P.indptr


class JointProblem:
    """Every tracker length and leg reading of one calibration as whitened residuals of the
    stations, the poses and the legs (a :class:`~calibench.estimators.identification.problem.
    Problem`, n poses, k reflectors).

    Columns (9 + 6 n + 42): the stations' x, y, z; each pose's left rotation increment
    (omega, rad) and shift (mm); each leg's r, B, l. Rows (9 + 3 k n + 6 n): the nests' lengths
    [station, nest], the reflectors' [pose, reflector, station], the legs' readings [pose, leg].
    Its Jacobian is a scipy.sparse CSR matrix with a fixed pattern.

    Parameters
    ----------
    obs : the measurements (:class:`TrackerObservations`).
    stations, R, t, r, B, l : the start, (3, 3), (n, 3, 3), (n, 3), (6, 3), (6, 3), (6,).
    """

    def __init__(self, obs: TrackerObservations, stations, R, t, r, B, l):
        self.obs = obs
        f = np.asarray
        self.initial = JointState(
            f(stations, float), f(R, float), f(t, float), f(r, float), f(B, float), f(l, float)
        )
        n, k = len(self.initial.R), len(obs.reflectors)
        self.n, self.k = n, k
        w = 1 / obs.sigma()
        self.w_nest, self.w_refl, self.w_leg = (
            w[:9].reshape(3, 3),
            w[9 : 9 + 3 * n * k].reshape(n, k, 3),
            w[9 + 3 * n * k :].reshape(n, 6),
        )
        self.pose0 = N_STATIONS  # the first pose column
        self.leg0 = N_STATIONS + 6 * n  # the first leg column
        self.names = (
            tuple(f"station{s + 1}_{c}" for s in range(3) for c in "xyz")
            + tuple(f"pose{i + 1}_{p}" for i in range(n) for p in POSE_PARAMS)
            + tuple(f"leg{i + 1}_{p}" for i in range(6) for p in LEG_PARAMS)
        )
        self.always = np.arange(len(self.names))  # every column is estimated
        self.groups: list[np.ndarray] = []
        self.shape = (9 + 3 * k * n + 6 * n, len(self.names))
        self._order, self._indices, self._indptr = _csr_order(*self._pattern(), self.shape)

    def _pattern(self) -> tuple[np.ndarray, np.ndarray]:
        """Rows and columns (nnz,) of the Jacobian's entries, in the order :meth:`jacobian`
        computes them: nests [station, nest, xyz]; reflectors [pose, reflector, station, (the
        station's xyz, the pose's six)]; legs [pose, leg, (the pose's six, the leg's seven)]."""
        n, k, p0, l0 = self.n, self.k, self.pose0, self.leg0
        s, c = np.arange(3), np.arange(3)
        nest_rows = np.repeat(np.arange(9), 3)
        nest_cols = np.broadcast_to((3 * s[:, None] + c)[:, None, :], (3, 3, 3)).ravel()
        i, f = np.arange(n)[:, None, None, None], np.arange(k)[None, :, None, None]
        st = s[None, None, :, None]
        refl_rows = np.broadcast_to(9 + (i * k + f) * 3 + st, (n, k, 3, 9)).ravel()
        refl_cols = np.concatenate(
            [
                np.broadcast_to(3 * st + c, (n, k, 3, 3)),
                np.broadcast_to(p0 + 6 * i + np.arange(6), (n, k, 3, 6)),
            ],
            axis=3,
        ).ravel()
        i, leg = np.arange(n)[:, None, None], np.arange(6)[None, :, None]
        leg_rows = np.broadcast_to(9 + 3 * k * n + 6 * i + leg, (n, 6, 13)).ravel()
        leg_cols = np.concatenate(
            [
                np.broadcast_to(p0 + 6 * i + np.arange(6), (n, 6, 6)),
                np.broadcast_to(l0 + 7 * leg + np.arange(7), (n, 6, 7)),
            ],
            axis=2,
        ).ravel()
        return np.r_[nest_rows, refl_rows, leg_rows], np.r_[nest_cols, refl_cols, leg_cols]

    def start(self) -> JointState:
        """The state the adjustment starts from (the sequential pipeline's estimate)."""
        return self.initial

    def _vectors(self, s: JointState):
        """The measured lines' vectors at ``s``: nests (3 s, 3 j, 3) from the stations,
        reflectors (n, k, 3 s, 3) from the stations with the rotated reflectors (n, k, 3), and
        legs (n, 6, 3) from the base hinges with the rotated platform hinges (n, 6, 3)."""
        v_nest = self.obs.nests[None, :, :] - s.stations[:, None, :]
        Rf = np.einsum("nij,kj->nki", s.R, self.obs.reflectors)
        v_refl = (Rf + s.t[:, None, :])[:, :, None, :] - s.stations[None, None, :, :]
        Rr = np.einsum("nij,lj->nli", s.R, s.r)
        v_leg = Rr + s.t[:, None, :] - s.B[None]
        return v_nest, v_refl, Rf, v_leg, Rr

    def residuals(self, s: JointState) -> np.ndarray:
        """Whitened residuals (9 + 3 k n + 6 n,): measured length minus modelled, over sigma."""
        v_nest, v_refl, _, v_leg, _ = self._vectors(s)
        obs = self.obs
        return np.r_[
            ((np.linalg.norm(v_nest, axis=2) - obs.nest_lengths) * self.w_nest).ravel(),
            ((np.linalg.norm(v_refl, axis=3) - obs.reflector_lengths) * self.w_refl).ravel(),
            ((np.linalg.norm(v_leg, axis=2) - s.l[None] - obs.readings) * self.w_leg).ravel(),
        ]

    def jacobian(self, s: JointState) -> sparse.csr_matrix:
        """d residuals / d step (9 + 3 k n + 6 n, 9 + 6 n + 42), sparse CSR: a length's
        derivative along its unit vector u is u on the far end and -u on the near one; a
        rotation increment omega moves a rotated point p by omega x p, so the length by
        u . (omega x p) = omega . (p x u)."""
        v_nest, v_refl, Rf, v_leg, Rr = self._vectors(s)
        un = v_nest / np.linalg.norm(v_nest, axis=2)[..., None]
        ur = v_refl / np.linalg.norm(v_refl, axis=3)[..., None]
        ul = v_leg / np.linalg.norm(v_leg, axis=2)[..., None]
        n, k = self.n, self.k
        nest = -un * self.w_nest[..., None]
        refl = (
            np.concatenate(
                [-ur, np.cross(np.broadcast_to(Rf[:, :, None, :], ur.shape), ur), ur], axis=3
            )
            * self.w_refl[..., None]
        )
        legs = (
            np.concatenate([np.cross(Rr, ul), ul, leg_derivatives(s.R, ul)], axis=2)
            * self.w_leg[..., None]
        )
        data = np.r_[nest.ravel(), refl.reshape(n * k * 3 * 9), legs.ravel()]
        return sparse.csr_matrix((data[self._order], self._indices, self._indptr), shape=self.shape)

    def update(self, s: JointState, step: np.ndarray) -> JointState:
        """The state moved by ``step`` (9 + 6 n + 42,): the poses turned on the left."""
        dp = step[self.pose0 : self.leg0].reshape(self.n, 6)
        legs = step[self.leg0 :].reshape(6, 7)
        return JointState(
            s.stations + step[: self.pose0].reshape(3, 3),
            np.einsum("nij,njk->nik", rotvecs_to_matrices(dp[:, :3]), s.R),
            s.t + dp[:, 3:],
            s.r + legs[:, :3],
            s.B + legs[:, 3:6],
            s.l + legs[:, 6],
        )

    def values(self, s: JointState) -> np.ndarray:
        """Every parameter's value (9 + 6 n + 42,): stations mm, each pose's rotation vector
        (rad) and shift (mm), each leg's r, B, l (mm)."""
        poses = np.c_[matrix_to_rotvec(s.R).reshape(self.n, 3), s.t]
        return np.r_[s.stations.ravel(), poses.ravel(), np.c_[s.r, s.B, s.l].ravel()]

    def scales(self) -> np.ndarray:
        """Typical sizes of the errors: 1 mm for a position or a length, 1 mrad for a turn."""
        pose = np.tile([1e-3, 1e-3, 1e-3, 1.0, 1.0, 1.0], self.n)
        return np.r_[np.ones(N_STATIONS), pose, np.ones(N_LEGS)]

    def reference(self) -> np.ndarray:
        """Every column sets the basis's rank tolerance."""
        return np.ones(len(self.names), bool)

    def legs(self) -> slice:
        """The legs' 42 columns (a, b, c, m, n, q, l per leg)."""
        return slice(self.leg0, None)


def every_column(problem: JointProblem) -> Basis:
    """The basis that keeps every column: the joint problem is regular by design (three stations
    from three nests each, a pose from three reflectors, a leg from its readings over the poses),
    and a rank-revealing QR of its dense Jacobian would cost more than the solve."""
    return Basis(kept=np.arange(len(problem.names)), dropped={})


def joint_information(obs: TrackerObservations, stations, R, t, r, B, l) -> np.ndarray:
    """The legs' 42 x 42 covariance from the full Fisher information at the given values, with
    the stations and poses as nuisance parameters (the legs' block of the inverse of the whole
    normal matrix). At the truth this is the Cramer-Rao bound of any unbiased estimator of the
    legs from these measurements."""
    problem = JointProblem(obs, stations, R, t, r, B, l)
    return inverse_normal(problem.jacobian(problem.start()), last=N_LEGS)[0]


def adjust_jointly(
    obs: TrackerObservations, stations, R, t, r, B, l, iterations: int = 20
) -> JointCalibration:
    """Maximum likelihood over stations, poses and legs together, from a start close enough (the
    one-step pipeline's): every length and reading weighted by its 1-sigma, solved by the one
    identification solver (Levenberg-Marquardt, at most ``iterations``).

    The pipeline fixes the stations from three lengths each and the poses from the tracker alone;
    here the legs' readings also inform the poses and every pose informs the stations, which the
    sequential estimate leaves on the table. The stated sigma are a datasheet's, not the truth:
    the variance factor of the whitened residuals (1 when the datasheet is right) rescales the
    covariance, and is reported as rms.

    Raises
    ------
    numpy.linalg.LinAlgError
        When the normal matrix is singular at the end (a set-up that cannot locate everything).
    """
    problem = JointProblem(obs, stations, R, t, r, B, l)
    ident = identify(
        problem,
        every_column(problem),
        max_iter=iterations,
        xtol=JOINT_XTOL,
        rounding=JOINT_COST_ROUNDING,
        finish=True,
        damping=JOINT_DAMPING,
    )
    s = ident.state
    legs = problem.legs()
    assert ident.cov is not None
    return JointCalibration(
        s.stations, s.R, s.t, s.r, s.B, s.l, ident.cov[legs, legs], ident.rms, ident.converged
    )
