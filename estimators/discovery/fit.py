"""The linear layer of discovery: a residual signal, its terms' columns, held-out residuals and
fits."""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy import linalg

from calibench.estimators.discovery.effect import Drivers
from calibench.estimators.discovery.robust import long_run_cov, wider


@dataclasses.dataclass
class Signal:
    """One residual series: ``r`` (m,) = recording - simulation, ``base`` (m, p) the scene
    model's free columns (calibrated with the data), ``sample`` (m,) the sample of each row,
    ``u`` (m,) the position along the axis (periodogram), ``axis`` the effects' axis key."""

    name: str
    axis: str
    r: np.ndarray
    base: np.ndarray
    sample: np.ndarray
    u: np.ndarray | None = None


def prior_rows(terms_at: list[tuple], n_cols: int) -> np.ndarray:
    """The rows (p, n_cols) a zero-mean Gaussian prior on some terms' coefficients adds to a least
    squares whose columns are laid out as ``terms_at`` says ((term, first column, width) each):
    one row per coefficient of a term with a ``prior_weight`` (its k weights: the signal's noise
    over the prior's std of each coefficient, so a row weighs as one measurement of that
    precision would). Terms without one add no rows."""
    rows = []
    for t, at, k in terms_at:
        w = getattr(t, "prior_weight", ())
        if len(w):
            P = np.zeros((k, n_cols))
            P[np.arange(k), at + np.arange(k)] = w
            rows.append(P)
    return np.vstack(rows) if rows else np.zeros((0, n_cols))


def lstsq(X, r):
    """Least squares on scaled columns: QR with column pivoting (LAPACK's gelsy), which handles a
    rank-deficient X as the SVD does at a fraction of its cost on tall matrices."""
    if X.shape[1] == 0:
        return np.zeros(0)
    scale = np.linalg.norm(X, axis=0)
    scale[scale == 0] = 1.0
    return (
        linalg.lstsq(X / scale, r, cond=1e-12, lapack_driver="gelsy", check_finite=False)[0] / scale
    )


FIXED = "fixed search"  # the cache's tag of a search's columns fixed on a fold's training rows
BASIS = "basis"  # and of the orthonormal basis of a fold's training rows beside the terms before


def keep_fixed(cache: dict, terms: list) -> None:
    """Drop the cached fixed searches of ``cache`` that no longer sit in ``terms``' order (after
    a selection round: only the accepted terms' fixes are asked for again). In place."""
    ids = tuple(id(t) for t in terms)
    for key in [k for k in cache if isinstance(k, tuple) and k[0] in (FIXED, BASIS)]:
        chain = key[2] + ((key[3],) if key[0] == FIXED else ())
        if chain != ids[: len(chain)]:
            del cache[key]


def term_columns(
    term, drivers, sig: Signal, others: np.ndarray, train: np.ndarray | None, cache: dict
):
    """Columns (m, k) of one term, its shape fixed on the training rows where it has one
    (``train`` (m,) bool; None: all rows)."""
    if hasattr(term, "fix"):  # a searched shape (a period, a harmonic), on the training rows
        rows = np.ones(len(sig.r), bool) if train is None else train
        return term.fix(sig.r, others, rows, drivers).columns(drivers)
    if term.key not in cache:
        cache[term.key] = term.columns(drivers)
    return cache[term.key]


def cv_residuals(
    sig: Signal, terms: list, drivers: Drivers, fold: np.ndarray, cache: dict
) -> np.ndarray:
    """Held-out residuals (m,): each fold predicted from a fit to the others (``fold`` per
    sample)."""
    rows_fold = fold[sig.sample]
    out = np.empty_like(sig.r)
    for f in np.unique(rows_fold):
        test = rows_fold == f
        train = ~test
        X = sig.base
        prefix: tuple = ()
        at = []
        for t in terms:
            # A searched shape depends on the fold and on the terms before it, nothing else: the
            # same search beside the same terms is fixed once (a selection round re-evaluates the
            # accepted terms beside every candidate).
            key = (FIXED, int(f), prefix, id(t)) if hasattr(t, "fix") else None
            if key is not None and key in cache:
                cols = cache[key]
            elif key is not None and getattr(t, "takes_basis", False) and X.shape[1]:
                # the searches beside the same terms share the basis of their training rows
                bkey = (BASIS, int(f), prefix)
                if bkey not in cache:
                    cache[bkey] = np.linalg.qr(X[train])[0]
                cols = t.fix(sig.r, X, train, drivers, basis=cache[bkey]).columns(drivers)
                cache[key] = cols
            else:
                cols = term_columns(t, drivers, sig, X, train, cache)
                if key is not None:
                    cache[key] = cols
            at.append((t, X.shape[1], cols.shape[1]))
            X = np.hstack([X, cols])
            prefix += (id(t),)
        P = prior_rows(at, X.shape[1])
        coef = lstsq(np.vstack([X[train], P]), np.r_[sig.r[train], np.zeros(len(P))])
        out[test] = sig.r[test] - X[test] @ coef
    return out


def session_residuals(
    sig: Signal,
    terms: list,
    drivers: Drivers,
    session: np.ndarray,
    register: np.ndarray,
    cache: dict,
) -> np.ndarray:
    """Residuals (m,) of whole sessions held out: each session predicted by a fit to the others.

    What belongs to the held-out session alone, the columns that are zero on every training row
    (its frame, its own phase of a harmonic, and a correction of its own to each term whose
    ``session_refit`` says a power-up may set it anew), is unknown to the others' fit: fitted on the
    session's ``register`` rows (bool per sample) with the rest held as the others fitted it, and
    the session's other rows are scored. A correction carries a zero-mean prior of the term's
    ``session_prior`` (its coefficients' std, toward the value the others fitted). Those
    residuals are returned; the registration rows' are NaN.

    Parameters
    ----------
    session : (n_samples,) int, each sample's session.
    register : (n_samples,) bool, the rows that register a held-out session.
    """
    rows_session, rows_register = session[sig.sample], register[sig.sample]
    out = np.full_like(sig.r, np.nan)
    for k in np.unique(rows_session):
        test = rows_session == k
        train = ~test
        X, at, held = sig.base, [], []
        for t in terms:
            # a search is fixed once per session held out, on the first list of terms asked for
            # (the full model: a term left out beside it moves its frequency by a hair)
            key = ("session", int(k), id(t)) if hasattr(t, "fix") else None
            if key is not None and key in cache:
                cols = cache[key]
            else:
                cols = term_columns(t, drivers, sig, X, train, cache)
                if key is not None:
                    cache[key] = cols
            at.append((t, X.shape[1], cols.shape[1]))
            X = np.hstack([X, cols])
            if getattr(t, "session_refit", False):  # a correction of its own in the session
                std = getattr(t, "session_prior", np.inf)  # inf: no prior
                held += [(X.shape[1] + i, std) for i in range(cols.shape[1])]
                X = np.hstack([X, cols * test[:, None]])
        P = prior_rows(at, X.shape[1])
        coef = lstsq(np.vstack([X[train], P]), np.r_[sig.r[train], np.zeros(len(P))])
        own = ~np.any(X[train] != 0, axis=0)
        reg, judged = test & rows_register, test & ~rows_register
        r = sig.r - X[:, ~own] @ coef[~own]
        # a correction's zero-mean prior (the others' value), as rows weighted by their fit's
        # scatter per value: the estimator register_session scores a new session with
        noise = rms(r[train])
        Q = np.zeros((len(held), int(own.sum())))
        for row, (col, std) in enumerate(held):
            Q[row, np.searchsorted(np.flatnonzero(own), col)] = noise / std
        c_own = lstsq(np.vstack([X[reg][:, own], Q]), np.r_[r[reg], np.zeros(len(Q))])
        out[judged] = r[judged] - X[judged][:, own] @ c_own
    return out


def rms(v) -> float:
    """Root mean square of ``v`` (m,); 0 for an empty array."""
    return float(np.sqrt(np.mean(np.square(v)))) if len(v) else 0.0


def fit_terms(
    sig: Signal,
    terms: list,
    drivers: Drivers,
    cache: dict,
    sigma: float | None,
    robust: bool = False,
):
    """All-data fit: fixed shapes (periods refined), coefficients, covariance, residual.

    The covariance takes the larger of the repeatability and the residual scatter (inflated
    for correlation by the caller through ``sigma``), so a poor model cannot look precise.
    ``robust``: each coefficient's variance is also at least the sandwich's over batches of
    consecutive samples (:mod:`robust`), so a slow drift the noise model does not know of cannot
    make a term look precise either.
    """
    fixed, X = [], sig.base
    for t in terms:
        if hasattr(t, "fix"):
            t = t.fix(sig.r, X, np.ones(len(sig.r), bool), drivers)
            cols = t.columns(drivers)
        else:
            cols = term_columns(t, drivers, sig, X, None, cache)
        fixed.append((t, X.shape[1], cols.shape[1]))
        X = np.c_[X, cols]
    P = prior_rows(fixed, X.shape[1])
    coef = lstsq(np.vstack([X, P]), np.r_[sig.r, np.zeros(len(P))])
    res = sig.r - X @ coef
    s_res = float(np.sqrt(res @ res / max(len(res) - X.shape[1], 1)))
    s = max(s_res, sigma or 0.0)
    # the covariance of the estimate the prior's rows shaped: theirs beside the data's
    XP = np.vstack([X, P])
    scale = np.linalg.norm(XP, axis=0)
    scale[scale == 0] = 1.0
    Xs = XP / scale
    cov = np.linalg.pinv(Xs.T @ Xs) / np.outer(scale, scale) * s * s
    if robust:
        cov = wider(cov, long_run_cov(X, res, sig.sample, P))
    return fixed, coef, cov, res


def refined(sig: Signal, fixed: list, drivers: Drivers) -> list | None:
    """The fixed terms of :func:`fit_terms`, each shape that can refine itself (a period) refined
    beside every other term's columns; None when none can. In the selection a searched shape is
    fixed beside the terms accepted before it only, so one accepted later (a thermal slope of the
    same axis) leaves it a few of its std off, and every coefficient's std too narrow."""
    if not any(hasattr(t, "refine") for t, _, _ in fixed):
        return None
    cols = [t.columns(drivers) for t, _, _ in fixed]
    out = []
    for i, (t, _, _) in enumerate(fixed):
        if hasattr(t, "refine"):
            others = np.hstack([sig.base] + [c for j, c in enumerate(cols) if j != i])
            t = t.refine(sig.r, others, drivers)
        out.append(t)
    return out


def confounded(
    sig: Signal, terms: list, candidate, drivers: Drivers, cache: dict, limit: float = 0.9
) -> float:
    """The fraction of a candidate's column(s) that the scene model and the accepted terms
    already span (1 = indistinguishable). Above ``limit`` the data cannot tell them apart."""
    X = sig.base
    for t in terms:
        X = np.c_[X, term_columns(t, drivers, sig, X, np.ones(len(sig.r), bool), cache)]
    C = term_columns(candidate, drivers, sig, X, np.ones(len(sig.r), bool), cache)
    C = C - C.mean(0)
    if not np.any(C):
        return 1.0
    Q, _ = np.linalg.qr(X)
    left = C - Q @ (Q.T @ C)
    return float(1 - np.sum(left**2) / np.sum(C**2))
