"""Compensation models for a two-axis table's planar positioning error (the vision-stage seed).

Conventions: ``u, v`` are scale readings (mm) relative to a reference point; an error is
``true position - reading`` (um) at that reading, one model per axis. A compensated controller
commands the reading s that satisfies s + e(s) = target.

- :class:`LineRuler` (the seed's Eq. 3-4): the error measured at the graduations of a ruler laid
  along one axis, linearly interpolated between them, a function of that axis's reading only.
- :func:`fit_polynomial` (Eq. 5-9 for degree 3: 10 coefficients a0..a9 on 1, u, v, u^2, uv, v^2,
  u^3, u^2 v, u v^2, v^3), least squares; any total degree.
- :func:`select_model`: the better model, by k-fold cross-validation among polynomials of any
  degree and the cubic plus a periodic term along the axis's own coordinate (a scale's or a
  screw's periodic error), its period searched too.
"""

from __future__ import annotations

import dataclasses
from typing import Literal, overload

import numpy as np

MONOMIAL_SCALE_MM = 100.0  # monomials are built on u / 100 mm for conditioning


def monomial_powers(degree: int) -> list[tuple[int, int]]:
    """(i, j) of u^i v^j, by total degree then decreasing i: degree 3 gives Eq. 5's order."""
    return [(d - j, j) for d in range(degree + 1) for j in range(d + 1)]


def design(
    u: np.ndarray, v: np.ndarray, degree: int, period_mm: float | None = None, along: int = 0
) -> np.ndarray:
    """Monomials of (u, v) / 100 mm up to ``degree``, then (with ``period_mm``) sin and cos of
    2 pi w / period with w = u (``along`` 0) or v (1); shape (n, n_terms)."""
    a, b = np.asarray(u, float) / MONOMIAL_SCALE_MM, np.asarray(v, float) / MONOMIAL_SCALE_MM
    p = np.array(monomial_powers(degree))
    A = a[..., None] ** p[:, 0] * b[..., None] ** p[:, 1]
    if period_mm is None:
        return A
    w = 2 * np.pi * (np.asarray(u, float) if along == 0 else np.asarray(v, float)) / period_mm
    return np.concatenate([A, np.sin(w)[..., None], np.cos(w)[..., None]], axis=-1)


@dataclasses.dataclass(frozen=True)
class Polynomial:
    """A bivariate polynomial error model, optionally plus one periodic term along one axis.

    ``coef`` (n_terms,): monomial coefficients in um / mm^(i+j), then (with a period) the sine
    and cosine amplitudes in um.
    """

    degree: int
    coef: np.ndarray
    rmse: float  # sqrt(SSE / (n - n_terms)), um
    period_mm: float | None = None
    along: int = 0

    @property
    def name(self) -> str:
        """The model's name (``linear``, ``quadratic``, ``cubic``, ...)."""
        if self.period_mm is None:
            return f"polynomial of degree {self.degree}"
        return (
            f"degree-{self.degree} polynomial + period {self.period_mm:.1f} mm along "
            f"{'XY'[self.along]}"
        )

    def __call__(self, u, v) -> np.ndarray:
        return design(u, v, self.degree, self.period_mm, self.along) @ (self.coef * self._scales())

    def _scales(self) -> np.ndarray:
        s = [MONOMIAL_SCALE_MM ** (i + j) for i, j in monomial_powers(self.degree)]
        return np.array(s + ([1.0, 1.0] if self.period_mm is not None else []))

    def coef_std(self, u: np.ndarray, v: np.ndarray, sigma_um: float) -> np.ndarray:
        """1-sigma of ``coef`` for independent errors of ``sigma_um`` at the fitted points."""
        A = design(u, v, self.degree, self.period_mm, self.along)
        return sigma_um * np.sqrt(np.diag(np.linalg.inv(A.T @ A))) / self._scales()


@overload
def least_squares(
    A: np.ndarray, e: np.ndarray, with_std: Literal[True] = ...
) -> tuple[np.ndarray, np.ndarray, float, float]: ...


@overload
def least_squares(
    A: np.ndarray, e: np.ndarray, with_std: Literal[False]
) -> tuple[np.ndarray, None, None, None]: ...


def least_squares(
    A: np.ndarray, e: np.ndarray, with_std: bool = True
) -> tuple[np.ndarray, np.ndarray | None, float | None, float | None]:
    """The one linear least-squares fitter of the error maps: coefficients c (p,) of
    A (n, p) @ c ~ e (n,) by QR, their 1-sigma (p,) from the residuals, the dof-adjusted RMSE
    sqrt(SSE / (n - p)) and the SSE. ValueError when n <= p or the columns are dependent.
    Several maps on the same points at once: e (n, k) gives c and std (p, k), RMSE and SSE (k,).
    ``with_std`` False: c alone is wanted (a cross-validation's fold), the rest is None."""
    n, p = A.shape
    if n <= p:
        raise ValueError(f"{n} points cannot fit {p} coefficients")
    Q, R = np.linalg.qr(A)
    d = np.abs(np.diag(R))
    if d.min() < 1e-9 * d.max():
        raise ValueError("degenerate points: they do not span the model")
    e = np.asarray(e, float)
    c = np.linalg.solve(R, Q.T @ e)
    if not with_std:
        return c, None, None, None
    r = e - A @ c
    if e.ndim == 1:
        sse = float(r @ r)
        rmse = float(np.sqrt(sse / (n - p)))
    else:
        sse = np.sum(r * r, axis=0)
        rmse = np.sqrt(sse / (n - p))
    std = np.multiply.outer(np.sqrt(np.sum(np.linalg.inv(R) ** 2, axis=1)), rmse)
    return c, std, rmse, sse


def fit_polynomial(
    u: np.ndarray,
    v: np.ndarray,
    err_um: np.ndarray,
    degree: int = 3,
    period_mm: float | None = None,
    along: int = 0,
) -> Polynomial:
    """Least-squares fit; (n,), (n,), (n,) -> Polynomial. Degree 3 alone is the seed's Eq. 5-9."""
    A = design(u, v, degree, period_mm, along)
    n, p = A.shape
    if n <= p:
        raise ValueError(f"{n} points cannot fit {p} coefficients of a degree-{degree} polynomial")
    try:
        c, _, rmse, _ = least_squares(A, err_um)
    except ValueError:
        raise ValueError("degenerate points: they do not span the polynomial") from None
    model = Polynomial(degree=degree, coef=c, rmse=rmse, period_mm=period_mm, along=along)
    return dataclasses.replace(model, coef=c / model._scales())


def cv_rms(u, v, err_um, folds: int = 10, seed: int = 0, **model) -> tuple[float, float]:
    """k-fold cross-validated RMS error (um) of ``fit_polynomial(..., **model)``, and the
    standard error of its mean square (from the spread of the folds), um^2."""
    n = len(err_um)
    fold = np.empty(n, int)
    fold[np.random.default_rng(seed).permutation(n)] = np.arange(n) % folds
    # the design once for every fold; each fold's fit and prediction as fit_polynomial and
    # Polynomial.__call__ make them (coefficients through the model's scales and back)
    A = design(u, v, model.get("degree", 3), model.get("period_mm"), model.get("along", 0))
    scales = Polynomial(model.get("degree", 3), np.empty(0), 0.0, model.get("period_mm"))._scales()
    e = np.asarray(err_um, float)
    mse = np.empty(folds)
    for k in range(folds):
        train, test = fold != k, fold == k
        if train.sum() <= A.shape[1]:
            raise ValueError(
                f"{train.sum()} points cannot fit {A.shape[1]} coefficients of a degree-"
                f"{model.get('degree', 3)} polynomial"
            )
        try:
            c = least_squares(A[train], e[train], with_std=False)[0]
        except ValueError:
            raise ValueError("degenerate points: they do not span the polynomial") from None
        mse[k] = float(np.mean((e[test] - A[test] @ ((c / scales) * scales)) ** 2))
    return float(np.sqrt(mse.mean())), float(mse.std(ddof=1) / np.sqrt(folds))


def cv_rms_periodic(
    u, v, err_um, periods_mm: np.ndarray, along: int, folds: int = 10, seed: int = 0
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`cv_rms` of the cubic plus a periodic term along ``along`` for every period (k,) at
    once: (rms (k,), standard error of the mean square (k,)). In each fold the cubic's columns
    are factored once and each period's sine and cosine are fitted to what the cubic leaves
    (Frisch-Waugh: the same least squares as the joint fit)."""
    u, v, e = (np.asarray(a, float) for a in (u, v, err_um))
    n = len(e)
    fold = np.empty(n, int)
    fold[np.random.default_rng(seed).permutation(n)] = np.arange(n) % folds
    w = 2 * np.pi * (u if along == 0 else v)[:, None] / np.asarray(periods_mm, float)[None, :]
    S = np.stack([np.sin(w), np.cos(w)], axis=1)  # (n, 2, k)
    A = design(u, v, 3)
    mse = np.empty((folds, S.shape[2]))
    for f in range(folds):
        tr, te = fold != f, fold == f
        Q, R = np.linalg.qr(A[tr])
        St = S[tr]
        S_r = St - np.einsum(
            "ni,ijk->njk", Q, np.einsum("ni,njk->ijk", Q, St)
        )  # what the cubic leaves of each
        e_r = e[tr] - Q @ (Q.T @ e[tr])
        G = np.einsum("njk,nlk->kjl", S_r, S_r)  # (k, 2, 2)
        b = np.linalg.solve(G, np.einsum("njk,n->kj", S_r, e_r)[..., None])[..., 0]  # (k, 2)
        c = np.linalg.solve(R, Q.T @ (e[tr][:, None] - np.einsum("njk,kj->nk", St, b)))  # (10, k)
        pred = A[te] @ c + np.einsum("njk,kj->nk", S[te], b)
        mse[f] = np.mean((e[te][:, None] - pred) ** 2, axis=0)
    return np.sqrt(mse.mean(axis=0)), mse.std(axis=0, ddof=1) / np.sqrt(folds)


MODEL_DEGREES = range(1, 9)  # the polynomial degrees select_model tries by default


def select_model(
    u: np.ndarray,
    v: np.ndarray,
    err_um: np.ndarray,
    along: int,
    degrees=MODEL_DEGREES,
    periods_mm: np.ndarray | None = None,
    folds: int = 10,
) -> tuple[Polynomial, dict[str, float]]:
    """The simplest candidate within one standard error of the least cross-validated error
    (the one-standard-error rule: the minimum over many candidates, periods above all, is
    itself optimistic), refitted on all points.

    Candidates: polynomials of each degree, and the cubic plus a periodic term along ``along``
    (the axis whose own scale or screw would make it) for each period in ``periods_mm``
    (default 20 to 200 mm, log-spaced). Returns the model and {candidate: cv rms (um)}.
    """
    n = len(err_um)
    cands = [dict(degree=d) for d in degrees if len(monomial_powers(d)) < n * (folds - 1) / folds]
    span = float(np.ptp(u if along == 0 else v))
    periods = np.geomspace(20.0, min(200.0, span), 60) if periods_mm is None else periods_mm
    scored = [(c, *cv_rms(u, v, err_um, folds, **c)) for c in cands]
    rms_p, se_p = cv_rms_periodic(u, v, err_um, periods, along, folds)
    scored += [
        (dict(degree=3, period_mm=float(p), along=along), float(r), float(se))
        for p, r, se in zip(periods, rms_p, se_p)
    ]
    rms_min, se_min = min((rms, se) for _, rms, se in scored)
    within = [(_n_terms(c), rms, c) for c, rms, _ in scored if rms**2 <= rms_min**2 + se_min]
    best = min(within, key=lambda t: (t[0], t[1]))[2]
    return fit_polynomial(u, v, err_um, **best), {fit_name(c): rms for c, rms, _ in scored}


def _n_terms(c: dict) -> int:
    return len(monomial_powers(c["degree"])) + (2 if c.get("period_mm") is not None else 0)


def fit_name(c: dict) -> str:
    """A selected model's name in words, from its description ``c`` (degree, and period if it
    has one)."""
    if c.get("period_mm") is None:
        return f"degree {c['degree']}"
    return f"degree {c['degree']} + period {c['period_mm']:.1f} mm"


@dataclasses.dataclass(frozen=True)
class LineRuler:
    """Piecewise-linear error table along one axis (Eq. 3-4), constant across the other.

    readings_mm (k,) increasing: the axis's readings at the graduations; err_um (k,): the
    error there, true displacement minus reading displacement from graduation 0.
    """

    readings_mm: np.ndarray
    err_um: np.ndarray

    @classmethod
    def from_graduations(cls, readings_mm: np.ndarray, pitch_mm: float) -> LineRuler:
        """Eq. 3: e_k = k * pitch - (r_k - r_0)."""
        r = np.asarray(readings_mm, float)
        if len(r) < 2 or np.any(np.diff(r) <= 0):
            raise ValueError("a line ruler needs two or more graduations read in increasing order")
        k = np.arange(len(r))
        return cls(r, (k * pitch_mm - (r - r[0])) * 1000)

    def __call__(self, reading_mm) -> np.ndarray:
        """Eq. 4: linear interpolation between graduations, the end segments extended."""
        r, e = self.readings_mm, self.err_um
        x = np.asarray(reading_mm, float)
        i = np.clip(np.searchsorted(r, x) - 1, 0, len(r) - 2)
        return e[i] + (e[i + 1] - e[i]) * (x - r[i]) / (r[i + 1] - r[i])


def compensated_command(target_mm: np.ndarray, error_um) -> np.ndarray:
    """Readings s (n, 2) with s + e(s) = target (n, 2); ``error_um(s) -> (n, 2)`` um.

    Fixed-point iteration: it contracts because the error's slope is far below one. It stops
    when an iterate repeats the last one to the bit (every later one would too), at most 20.
    """
    t = np.atleast_2d(np.asarray(target_mm, float))
    s = t.copy()
    for _ in range(20):
        s_next = t - error_um(s) / 1000
        if np.array_equal(s_next, s):
            break
        s = s_next
    return s
