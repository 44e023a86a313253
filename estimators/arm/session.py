"""A new session of a calibrated arm: what belongs to the session, fitted on its registration rows.

A calibration carries the machine to a new set-up: its geometry, compliance and the joint-angle
terms every session shares. Two things belong to the session and are unknown there: the
instrument's frame, and the terms whose phase each power-up sets (an
:class:`~calibench.estimators.arm.terms.AngleTerm` with a ``recording``: a motor-side gear
harmonic). :func:`register_session` fits both on the rows set aside to register the session
(never on the rows that score it): a rigid registration first, then Gauss-Newton on the frame's
small turn and shift and the session terms' coefficients, the machine held as calibrated.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from calibench.estimators.arm.kinematics import in_readings, jacobian, pose, theta_index
from calibench.estimators.rotations import rigid_transform, rotvec_to_matrix, skew


@dataclasses.dataclass(frozen=True)
class SessionFit:
    """A session's frame and own terms.

    R, t : (3, 3), (3,) mm: instrument point = R @ base point + t.
    names : the session terms' coefficient names (``angle_<label><joint>_sin`` ...).
    coef : (k,) their values, rad.
    converged : False where Gauss-Newton ran out of iterations (the values its last iterate's).
    """

    R: np.ndarray
    t: np.ndarray
    names: tuple[str, ...]
    coef: np.ndarray
    converged: bool = True


# the angle terms a new session refits beside its frame: a gear train's harmonics (a power-up
# may set their phase) and a table over a joint's angle (what no law explains need not hold as
# it did), both held to the machine's values by SESSION_PRIOR_RAD (unregularised, a table's
# bands refitted on a fifth of a session's rows put a band few of them reach far off: a max of
# 19.8 mm on the UR10's A left out); an encoder's eccentricity stays with the machine
SESSION_LABELS = ("transmission", "table")

# The prior std (rad) of a session's correction to a shared term's coefficient, zero mean (the
# machine's value): a session moves a term by a fraction of it, and unregularised a coefficient
# few registration rows pin down is free to go far off. On the UR10's A, B and D each held out
# by discovery's own check (C unseen), the harmonics' corrections score alike from 3e-5 to 1e-3
# rad and a table's from 1e-4 up: 1e-4 is the tightest that costs neither.
SESSION_PRIOR_RAD = 1e-4


def corrections(terms) -> list:
    """Which of :func:`session_terms` correct a shared term (the machine's value, held with
    :data:`SESSION_PRIOR_RAD`) rather than stand for a per-recording one (its own, no prior)."""
    own = {dataclasses.replace(t, recording=None) for t in terms if t.recording is not None}
    return [t for t in session_terms(terms) if t not in own]


def session_terms(terms) -> list:
    """The terms a new session has its own coefficients of: one per per-recording term of the
    calibration (its copies for each training session counted once), as a shared term, and a
    correction to each shared gear harmonic (:data:`SESSION_LABELS`)."""
    out: dict = {}
    for t in terms:
        if t.recording is not None or t.label in SESSION_LABELS:
            shared = dataclasses.replace(t, recording=None)
            out.setdefault(shared, shared)
    return list(out.values())


def _names(t) -> tuple[str, ...]:
    """A session term's coefficient names, with its harmonic (two of one joint differ by it)."""
    if t.kind != "harmonic":
        return t.names
    return tuple(n.replace(f"{t.joint}_", f"{t.joint}_h{t.harmonic:g}_", 1) for n in t.names)


def session_columns(problem, state, q_rad: np.ndarray, terms, tool=None) -> np.ndarray:
    """How each session term's coefficients move the tool point in the base frame, (n, 3, k) mm
    per rad: a joint's angle error F(q_j) @ c turns the link back by it (the Jacobian taken at
    the readings: the sag's effect on it is second order), each row's of its ``tool`` (n,)
    (a branched arm's; None: the first)."""
    J = jacobian(problem.chain, P=pose(problem.chain, q_rad, state.delta, tool))
    # a joint's reading turns the joints that follow it too
    turns = in_readings(
        problem.chain, J[:, :, [theta_index(j) for j in range(1, q_rad.shape[1] + 1)]]
    )
    cols = [
        -turns[:, :, t.joint - 1][:, :, None] * t.functions(q_rad[:, t.joint - 1])[:, None]
        for t in terms
    ]
    return np.concatenate(cols, axis=2) if cols else np.zeros((len(q_rad), 3, 0))


# a session's Gauss-Newton has converged when its step moves the frame by less than this (rad and
# mm) and the terms by less than this (rad): round-off, for frames of metres and terms of mrad
STEP_TOL = 1e-11


def register_session(
    problem,
    state,
    q_rad: np.ndarray,
    xyz_mm: np.ndarray,
    rows: np.ndarray,
    iterations: int = 20,
    tool: np.ndarray | None = None,
) -> tuple[SessionFit, np.ndarray]:
    """Fit a new session's frame and own terms on its rows ``rows``.

    Parameters
    ----------
    problem : the calibration's :class:`~calibench.estimators.arm.point.PointProblem`.
    state : its fitted state (the machine, held).
    q_rad : (n, N) the session's readings; xyz_mm : (n, 3) its measured points.
    rows : (m,) the rows to register on (at least 3, and more than the session terms).
    tool : (n,) each row's tool (0-based) on a branched arm; None: the first.

    The corrections to shared terms carry a zero-mean prior of :data:`SESSION_PRIOR_RAD`, as
    prior rows weighted by the calibration's scatter per value (as discovery's
    :func:`~calibench.estimators.discovery.fit.session_residuals` does).

    Not on the identification core: a frame and a handful of terms from the closed-form frame
    (Kabsch) onwards, with a prior on the terms and no basis to choose (each term's columns are
    the calibrated arm's own, identifiable by construction); Gauss-Newton to round-off, at most
    ``iterations`` steps, ``converged`` said.

    Returns
    -------
    (SessionFit, (n, 3) the modelled points of every row in the session's frame)
    """
    terms = session_terms(problem.terms)
    p0 = problem.base_points(state, q_rad, tool=tool)
    cols = session_columns(problem, state, q_rad, terms, tool)
    R, t = rigid_transform(p0[rows], xyz_mm[rows])
    c = np.zeros(cols.shape[2])
    held = set(corrections(problem.terms))
    prior = np.concatenate([np.full(len(_names(u)), u in held) for u in terms] or [np.zeros(0)])
    noise = float(np.sqrt(np.mean((problem.y - problem.model(state)) ** 2)))
    # the prior's rows, on the coefficients: one per correction, weighing as a value would
    P = np.zeros((int(prior.sum()), 6 + len(c)))
    P[np.arange(len(P)), 6 + np.flatnonzero(prior)] = noise / SESSION_PRIOR_RAD
    converged = True
    for _ in range(iterations if len(c) else 0):
        p = p0[rows] + cols[rows] @ c
        Rp = p @ R.T
        e = xyz_mm[rows] - Rp - t
        A = np.concatenate(
            [-skew(Rp), np.broadcast_to(np.eye(3), (len(rows), 3, 3)), R @ cols[rows]], axis=2
        )
        A2 = np.vstack([A.reshape(-1, A.shape[2]), P])
        e2 = np.r_[e.ravel(), -P[:, 6:] @ c]
        step = np.linalg.lstsq(A2, e2, rcond=None)[0]
        R, t, c = rotvec_to_matrix(step[:3]) @ R, t + step[3:6], c + step[6:]
        converged = bool(np.max(np.abs(step)) < STEP_TOL)
        if converged:
            break
    names = tuple(n for term in terms for n in _names(term))
    return SessionFit(R, t, names, c, converged), (p0 + cols @ c) @ R.T + t
