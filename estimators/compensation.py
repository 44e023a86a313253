"""Compensation models for a two-axis table's planar positioning error (the vision-stage seed).

Conventions: ``u, v`` are scale readings (mm) relative to a reference point; an error is
``true position - reading`` (um) at that reading, one model per axis. A compensated controller
commands the reading s that satisfies s + e(s) = target.

- :class:`LineRuler` (the seed's Eq. 3-4): the error measured at the graduations of a ruler laid
  along one axis, linearly interpolated between them, a function of that axis's reading only.
- :func:`fit_polynomial` (Eq. 5-9 for degree 3: 10 coefficients a0..a9 on 1, u, v, u^2, uv, v^2,
  u^3, u^2 v, u v^2, v^3), least squares; any total degree.
- :func:`select_degree`: the degree by k-fold cross-validation (the better model).
"""

from __future__ import annotations

import dataclasses

import numpy as np

_SCALE = 100.0  # mm: monomials are built on u / 100 for conditioning


def monomial_powers(degree: int) -> list[tuple[int, int]]:
    """(i, j) of u^i v^j, by total degree then decreasing i: degree 3 gives Eq. 5's order."""
    return [(d - j, j) for d in range(degree + 1) for j in range(d + 1)]


def design(u: np.ndarray, v: np.ndarray, degree: int) -> np.ndarray:
    """Monomials of (u, v) / 100 mm up to ``degree``, shape (n, n_terms)."""
    a, b = np.asarray(u, float) / _SCALE, np.asarray(v, float) / _SCALE
    return np.stack([a**i * b**j for i, j in monomial_powers(degree)], axis=-1)


@dataclasses.dataclass(frozen=True)
class Polynomial:
    """A bivariate polynomial error model. ``coef`` (n_terms,) in um / mm^(i+j) (unscaled)."""

    degree: int
    coef: np.ndarray
    rmse: float  # sqrt(SSE / (n - n_terms)), um

    def __call__(self, u, v) -> np.ndarray:
        return design(u, v, self.degree) @ (self.coef * self._scales())

    def _scales(self) -> np.ndarray:
        return np.array([_SCALE ** (i + j) for i, j in monomial_powers(self.degree)])

    def coef_std(self, u: np.ndarray, v: np.ndarray, sigma_um: float) -> np.ndarray:
        """1-sigma of ``coef`` for independent errors of ``sigma_um`` at the fitted points."""
        A = design(u, v, self.degree)
        return sigma_um * np.sqrt(np.diag(np.linalg.inv(A.T @ A))) / self._scales()


def fit_polynomial(u: np.ndarray, v: np.ndarray, err_um: np.ndarray, degree: int = 3) -> Polynomial:
    """Least-squares polynomial of total ``degree``; (n,), (n,), (n,) -> Polynomial."""
    A = design(u, v, degree)
    n, p = A.shape
    if n <= p:
        raise ValueError(f"{n} points cannot fit {p} coefficients of a degree-{degree} polynomial")
    if np.linalg.matrix_rank(A) < p:
        raise ValueError("degenerate points: they do not span the polynomial")
    c, *_ = np.linalg.lstsq(A, np.asarray(err_um, float), rcond=None)
    r = err_um - A @ c
    scales = np.array([_SCALE ** (i + j) for i, j in monomial_powers(degree)])
    return Polynomial(degree=degree, coef=c / scales, rmse=float(np.sqrt(r @ r / (n - p))))


def select_degree(u: np.ndarray, v: np.ndarray, err_um: np.ndarray, degrees=range(1, 9), folds: int = 10,
                  seed: int = 0) -> tuple[int, dict[int, float]]:
    """Total degree with the least k-fold cross-validated RMS error; returns (degree, {d: rms})."""
    n = len(err_um)
    order = np.random.default_rng(seed).permutation(n)
    fold = np.empty(n, int)
    fold[order] = np.arange(n) % folds
    cv = {}
    for d in degrees:
        if len(monomial_powers(d)) >= n * (folds - 1) / folds:
            break
        sq = 0.0
        for k in range(folds):
            train, test = fold != k, fold == k
            m = fit_polynomial(u[train], v[train], err_um[train], d)
            sq += float(np.sum((err_um[test] - m(u[test], v[test])) ** 2))
        cv[d] = float(np.sqrt(sq / n))
    return min(cv, key=cv.get), cv


@dataclasses.dataclass(frozen=True)
class LineRuler:
    """Piecewise-linear error table along one axis (Eq. 3-4), constant across the other.

    readings_mm (k,) increasing: the axis's readings at the graduations; err_um (k,): the
    error there, true displacement minus reading displacement from graduation 0.
    """

    readings_mm: np.ndarray
    err_um: np.ndarray

    @classmethod
    def from_graduations(cls, readings_mm: np.ndarray, pitch_mm: float) -> "LineRuler":
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

    Fixed-point iteration: it contracts because the error's slope is far below one.
    """
    t = np.atleast_2d(np.asarray(target_mm, float))
    s = t.copy()
    for _ in range(20):
        s = t - error_um(s) / 1000
    return s
