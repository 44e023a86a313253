"""Positioning-error maps of a two-axis stage: the seed paper's bivariate quadratic (Eq. 1), and
the vision-stage seed's cubic (:func:`fit_cubic`) as ``calibench fit`` reports it.

``err(x, y) = c0 + c1 x + c2 y + c3 x^2 + c4 x y + c5 y^2`` with x, y the commanded position in
mm and err in mm, one map per axis. Goodness of fit as the paper's Table 3: SSE, R^2 and the
dof-adjusted RMSE = sqrt(SSE / (n - 6)).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from calibench.estimators.stage.compensation import (
    MONOMIAL_SCALE_MM,
    design,
    fit_polynomial,
    least_squares,
    monomial_powers,
)

COEF_NAMES = ("c0", "c1", "c2", "c3", "c4", "c5")
# c0..c5 are the coefficients of the degree-2 polynomial map of the vision stage's module, in the
# same monomial order (1, x, y, x^2, xy, y^2), fitted by the same least squares: one fitter
_POWERS = np.array([i + j for i, j in monomial_powers(2)])


@dataclasses.dataclass(frozen=True)
class QuadraticFit:
    """Least-squares quadratic map of one axis's error.

    coef : (6,) c0..c5 in mm, mm/mm, mm/mm^2.  std : (6,) their 1-sigma (from the residuals).
    r2 : None when the errors are all alike (nothing for the map to explain).
    """

    coef: np.ndarray
    std: np.ndarray
    sse: float
    r2: float | None
    rmse: float
    n: int

    def __call__(self, x_mm, y_mm) -> np.ndarray:
        return design(x_mm, y_mm, 2) @ (self.coef * MONOMIAL_SCALE_MM**_POWERS)

    def as_dict(self) -> dict:
        """The coefficients and fit figures as plain floats."""
        return {
            "coef": dict(zip(COEF_NAMES, map(float, self.coef))),
            "std": dict(zip(COEF_NAMES, map(float, self.std))),
            "sse": self.sse,
            "r2": self.r2,
            "rmse": self.rmse,
            "n": self.n,
        }


# The design of the stations centred and scaled to their span, its columns each of unit length:
# its smallest singular value is about 0.1 of its largest on a grid (wherever the grid lies); on a
# circle written to the micrometre (a ballbar's path), where 1, x^2 and y^2 repeat each other, 6e-7.
SPREAD_MIN = 1e-4


def check_spread(x_mm: np.ndarray, y_mm: np.ndarray, degree: int) -> None:
    """ValueError when the stations lie on a curve the degree's polynomial map cannot tell from
    its own terms (a line, a circle, any conic for the quadratic): the smallest singular value of
    the design, of the stations centred and scaled to their span and with unit columns, below
    :data:`SPREAD_MIN` of the largest. The fit would return coefficients with std of metres rather
    than fail."""
    x, y = np.asarray(x_mm, float), np.asarray(y_mm, float)
    span = max(np.ptp(x), np.ptp(y)) if len(x) else 0.0
    if span == 0:
        raise ValueError("degenerate stations: every one at the same place")
    # design() divides by MONOMIAL_SCALE_MM: the monomials are of the centred, scaled stations
    u, v = ((c - c.mean()) / span * MONOMIAL_SCALE_MM for c in (x, y))
    A = design(u, v, degree)
    norm = np.linalg.norm(A, axis=0)
    s = np.linalg.svd(A / np.where(norm > 0, norm, 1.0), compute_uv=False)
    if s[-1] < SPREAD_MIN * s[0]:
        raise ValueError(
            "degenerate stations: they lie on a line or a curve (a circle?) that the degree-"
            f"{degree} map cannot tell from its own terms; measure a grid"
        )


def fit_quadratic(x_mm: np.ndarray, y_mm: np.ndarray, err_mm: np.ndarray) -> QuadraticFit:
    """Fit one axis's error map, (n,), (n,), (n,) -> QuadraticFit. Needs n > 6 spread stations
    (:func:`check_spread`)."""
    e = np.asarray(err_mm, float)
    n = len(e)
    if n <= 6:
        raise ValueError(f"{n} stations: the quadratic map needs more than 6")
    check_spread(x_mm, y_mm, 2)
    try:
        c, std, rmse, sse = least_squares(design(x_mm, y_mm, 2), e)
    except ValueError:
        raise ValueError("degenerate stations: they do not span a quadratic in x and y") from None
    sst = float(np.sum((e - e.mean()) ** 2))
    unit = MONOMIAL_SCALE_MM**-_POWERS  # from the design's (x / 100 mm)^k to mm^-k
    return QuadraticFit(
        coef=c * unit,
        std=std * unit,
        sse=sse,
        r2=1 - sse / sst if sst > 0 else None,
        rmse=rmse,
        n=n,
    )


def quadratic_coefs(x_mm: np.ndarray, y_mm: np.ndarray, err_mm: np.ndarray) -> np.ndarray:
    """The coefficients c0..c5 of k maps on the same stations at once, (n,), (n,), (n, k) -> (6, k)
    (each column as :func:`fit_quadratic` fits it)."""
    c = least_squares(design(x_mm, y_mm, 2), np.asarray(err_mm, float))[0]
    return c * (MONOMIAL_SCALE_MM**-_POWERS)[:, None]


def compensated_command(
    x_target_mm, y_target_mm, fit_x: QuadraticFit, fit_y: QuadraticFit, iterations: int = 30
) -> tuple[np.ndarray, np.ndarray]:
    """Commands that land on the targets under the fitted maps: cmd + err(cmd) = target.

    Fixed-point iteration cmd <- target - err(cmd); it contracts because the maps' slopes are
    far below one.
    """
    xt, yt = np.asarray(x_target_mm, float), np.asarray(y_target_mm, float)
    xc, yc = xt.copy(), yt.copy()
    for _ in range(iterations):
        xc, yc = xt - fit_x(xc, yc), yt - fit_y(xc, yc)
    return xc, yc


CUBIC_NAMES = tuple(f"a{k}" for k in range(10))


@dataclasses.dataclass(frozen=True)
class CubicFit:
    """Least-squares cubic map of one axis's error (the vision-stage seed's Eq. 5-9), in the
    error's own unit (``calibench fit``: mm).

    coef : (10,) a0..a9 on 1, x, y, x^2, xy, y^2, x^3, x^2 y, x y^2, y^3 (per mm^k).
    std : (10,) their 1-sigma (from the residuals).
    sse, r2 (None when the errors are all alike), rmse = sqrt(sse / (n - 10)), n.
    """

    coef: np.ndarray
    std: np.ndarray
    sse: float
    r2: float | None
    rmse: float
    n: int

    def as_dict(self) -> dict:
        """The coefficients and fit figures as plain floats."""
        return {
            "coef": dict(zip(CUBIC_NAMES, map(float, self.coef))),
            "std": dict(zip(CUBIC_NAMES, map(float, self.std))),
            "sse": self.sse,
            "r2": self.r2,
            "rmse": self.rmse,
            "n": self.n,
        }


def fit_cubic(x_mm: np.ndarray, y_mm: np.ndarray, err: np.ndarray) -> CubicFit:
    """Fit one axis's error map by the cubic, (n,), (n,), (n,) -> CubicFit. Needs n > 10 points
    that span the cubic (ValueError otherwise, :func:`check_spread`)."""
    f = fit_polynomial(x_mm, y_mm, err, degree=3)
    check_spread(x_mm, y_mm, 3)
    r = err - f(x_mm, y_mm)
    sse = float(r @ r)
    sst = float(np.sum((err - err.mean()) ** 2))
    return CubicFit(
        coef=f.coef,
        std=f.coef_std(x_mm, y_mm, f.rmse),
        sse=sse,
        r2=1 - sse / sst if sst > 0 else None,
        rmse=f.rmse,
        n=len(err),
    )
