"""The tracker's frame and the legs' geometry from poses the tracker measured, one problem on the
identification core (:mod:`calibench.estimators.identification`).

Each reading is modelled on the tracker's pose (R_j (3, 3), t_j (3,), tracker frame) carried
into the base frame by the tracker-to-base frame (R_f, t_f)::

    reading_ij = | R_f R_j r_i + R_f t_j + t_f - B_i | - l_i

with leg i's platform hinge r_i, base hinge B_i and initial length l_i (mm). Unlike the joint
adjustment (:mod:`calibench.estimators.stewart.adjustment`) the poses are taken as measured: this
is discovery's registration and its geometry-only residual, where what is left after the frame and
the legs is the structure searched for.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from calibench.estimators.identification.basis import Basis, identifiable_basis
from calibench.estimators.identification.solver import Identification, identify
from calibench.estimators.rotations import matrix_to_rotvec, rotvec_to_matrix
from calibench.estimators.stewart.adjustment import LEG_PARAMS, POSE_PARAMS
from calibench.estimators.stewart.kinematics import leg_derivatives

FRAME = np.arange(6)  # the frame's columns: its left turn (rad), then its shift (mm)
# past the cost's rounding, Gauss-Newton's steps until none moves a parameter by more than this
# fraction of its std: the residual exact to far below the noise, where structure would hide. Not
# 1e-8: 48 columns of metre lengths, some nearly dependent, leave steps of ~1e-8 std of round-off
XTOL = 1e-6


@dataclasses.dataclass(frozen=True)
class RegistrationState:
    """The tracker-to-base frame (Rf (3, 3), tf (3,) mm) and the legs' r, B (6, 3), l (6,) mm."""

    Rf: np.ndarray
    tf: np.ndarray
    r: np.ndarray
    B: np.ndarray
    l: np.ndarray


class RegistrationProblem:
    """The readings (n, 6) mm of poses R (n, 3, 3), t (n, 3) measured in the tracker's frame, as
    a :class:`~calibench.estimators.identification.problem.Problem`: 6 frame columns, then each
    leg's seven (r, B, l), whitened by the readings' 1-sigma ``sigma_mm``."""

    def __init__(self, readings, R, t, start: RegistrationState, sigma_mm: float = 1.0):
        self.readings = np.asarray(readings, float)
        self.R, self.t = np.asarray(R, float), np.asarray(t, float)
        self.initial = start
        self.w = 1.0 / sigma_mm
        self.names = tuple(f"frame_{p}" for p in POSE_PARAMS) + tuple(
            f"leg{i + 1}_{p}" for i in range(6) for p in LEG_PARAMS
        )
        self.always = FRAME
        self.groups = [np.arange(6, len(self.names))]

    def start(self) -> RegistrationState:
        """The state the solve starts from."""
        return self.initial

    def legs(self, s: RegistrationState):
        """At ``s``: base-frame rotations (n, 3, 3), hinge points P (n, 6, 3), the legs' lengths
        L (n, 6) and unit vectors u (n, 6, 3), from the base hinge to the platform's."""
        R = np.einsum("ij,njk->nik", s.Rf, self.R)
        t = self.t @ s.Rf.T + s.tf
        P = np.einsum("nij,kj->nki", R, s.r) + t[:, None, :]
        v = P - s.B
        L = np.linalg.norm(v, axis=2)
        return R, P, L, v / L[..., None]

    def residuals(self, s: RegistrationState) -> np.ndarray:
        """Whitened residuals (6 n,): modelled reading minus measured, over sigma."""
        _, _, L, _ = self.legs(s)
        return ((L - s.l - self.readings) * self.w).ravel()

    def jacobian(self, s: RegistrationState) -> np.ndarray:
        """d residuals / d step (6 n, 48): a left turn w of the frame moves a hinge point P by
        w x P, so its leg's length by u . (w x P) = w . (P x u); a shift d by u . d."""
        R, P, _, u = self.legs(s)
        n = len(R)
        J = np.zeros((n, 6, len(self.names)))
        J[:, :, :3], J[:, :, 3:6] = np.cross(P, u), u
        own = leg_derivatives(R, u)  # (n, 6, 7): each reading's own leg's seven
        for i in range(6):
            J[:, i, 6 + 7 * i : 13 + 7 * i] = own[:, i]
        return J.reshape(6 * n, -1) * self.w

    def update(self, s: RegistrationState, step: np.ndarray) -> RegistrationState:
        """The state moved by ``step`` (48,): the frame turned on the left."""
        turn = rotvec_to_matrix(step[:3])
        legs = step[6:].reshape(6, 7)
        return RegistrationState(
            turn @ s.Rf,
            turn @ s.tf + step[3:6],
            s.r + legs[:, :3],
            s.B + legs[:, 3:6],
            s.l + legs[:, 6],
        )

    def values(self, s: RegistrationState) -> np.ndarray:
        """Every parameter's value (48,): the frame's rotation vector (rad) and shift (mm), each
        leg's r, B, l (mm)."""
        return np.r_[matrix_to_rotvec(s.Rf), s.tf, np.c_[s.r, s.B, s.l].ravel()]

    def scales(self) -> np.ndarray:
        """Typical sizes of the errors: 1 mrad for a turn, 1 mm for a position or a length."""
        return np.r_[1e-3, 1e-3, 1e-3, np.ones(3 + 42)]

    def reference(self) -> np.ndarray:
        """Every column sets the basis's rank tolerance."""
        return np.ones(len(self.names), bool)


def register_frame(problem: RegistrationProblem) -> Identification:
    """The frame alone (the legs at the start's, nominal): six unknowns, always identifiable from
    poses that turn."""
    return identify(problem, Basis(kept=FRAME, dropped={}), finish=True, xtol=XTOL)


def register_with_legs(problem: RegistrationProblem) -> Identification:
    """The frame and every leg parameter the poses identify (the identifiable basis: the base
    hinges turned and shifted together move the data as the frame does, so six are dropped)."""
    return identify(problem, identifiable_basis(problem), finish=True, xtol=XTOL)
