"""The identifiable basis of a least-squares problem: which parameters the data determine.

Column-pivoted QR of the scaled, whitened Jacobian, group by group (what is always estimated, then
each group on what the kept columns cannot explain): a column beyond the practical rank is a
parameter the data cannot tell from the others; it is dropped, with the kept parameters it moves
the data as.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np
from scipy import sparse
from scipy.linalg import lapack

from calibench.estimators.identification.problem import Problem


@dataclasses.dataclass(frozen=True)
class Basis:
    """Which columns are estimated (kept, indices into the problem's parameters) and which are
    dropped, each with why."""

    kept: np.ndarray
    dropped: dict[str, str]
    # how each dropped parameter moves the data as kept ones: {dropped: {kept: coefficient}},
    # in units of their typical sizes (the problem's scales()), first order at the basis's state
    partners: dict[str, dict[str, float]] = dataclasses.field(default_factory=dict)


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
    problem: Problem,
    state=None,
    rel_tol: float = 1e-4,
    explain: bool = True,
    note: Callable[[str, list[str]], str] | None = None,
) -> Basis:
    """Practical rank of the scaled, whitened Jacobian, group by group: ``problem.always`` (kept
    whatever the data), then each of ``problem.groups`` pivoted (QR) on what the kept columns
    cannot explain, so a later group's column that repeats an earlier one is the one dropped.

    Parameters
    ----------
    problem : Problem
        Its ``scales()`` make the columns comparable (each as the data move under a typical-size
        error of its parameter); the largest of its ``reference()`` columns sets the tolerance.
    state : the state to linearise at (default ``problem.start()``)
    rel_tol : float
        Relative to the largest reference column: a dependence that holds only up to the data's
        own scatter is a dependence.
    explain : bool
        False: the kept columns alone (no reasons, no partners), to compare two bases.
    note : callable, optional
        ``note(dropped name, partner names) -> str``, appended to a dropped parameter's reason
        (an arm's parallel axes: :func:`calibench.estimators.arm.kinematics.parallel_axes_note`).

    Returns
    -------
    Basis : kept (k,) sorted column indices; dropped in column order, each with what it moves the
    data as (partners in units of the parameters' typical sizes)
    """
    s = problem.start() if state is None else state
    names = problem.names
    # each column as the data move under a typical-size error of its parameter
    J = problem.jacobian(s)
    if sparse.issparse(J):  # the QR below is dense whatever the Jacobian
        J = sparse.csr_matrix(J).toarray()
    Js = J * problem.scales()
    if not np.isfinite(Js).all():  # geqp3 would return a basis of garbage
        raise np.linalg.LinAlgError("the Jacobian is not finite")
    norm = np.linalg.norm(Js, axis=0)
    reference = problem.reference()
    top = norm[reference].max(initial=0.0) if reference.any() else norm.max(initial=0.0)
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
    # each dropped column's largest partners
    largest3 = np.argsort(-np.abs(coefs), axis=0)[:3].T.tolist()
    for j, coef, order in zip(dropped.tolist(), coefs.T.tolist(), largest3):
        big = [(kept_names[k], coef[k]) for k in order if abs(coef[k]) > 0.05 * abs(coef[order[0]])]
        text = "moves the data as " + " + ".join(f"{n} ({c:+.2f})" for n, c in big)
        reasons[names[j]] = text + (note(names[j], [n for n, _ in big]) if note else "")
        partners[names[j]] = dict(zip(kept_names, coef))
    return Basis(kept=kept, dropped=reasons, partners=partners)
