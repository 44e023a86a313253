"""The vision stage's table calibrated with a circle plate (the seed's steps 1-3).

The plate's angle phi to the X motion comes from two circles of one row servoed to the image
centre. Each circle of the grid servoed in turn gives a point pair: its scale readings against
its nominal position on the plate (turned by the measured phi). The error (true - reading, um)
at the readings, relative to circle (0, 0), is modelled per axis by the seed's cubic
(:func:`~calibench.estimators.stage.compensation.fit_polynomial`, Eq. 5-9) and by the model
cross-validation prefers (:func:`~calibench.estimators.stage.compensation.select_model`);
:func:`compensation_models` sets them beside the line rulers (Eq. 3-4) as the controller would
use them.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence

import numpy as np

from calibench.estimators.stage.compensation import (
    LineRuler,
    Polynomial,
    fit_polynomial,
    select_model,
)


def plate_angle_rad(s_from_mm: np.ndarray, s_to_mm: np.ndarray) -> float:
    """The angle against X of the line between two circles' readings.

    Parameters
    ----------
    s_from_mm, s_to_mm : (2,) the scale readings (X, Y) at which each circle is on the optical axis.

    Returns
    -------
    The angle, rad, counter-clockwise from X.
    """
    d = np.asarray(s_to_mm) - np.asarray(s_from_mm)
    return float(np.arctan2(d[1], d[0]))


@dataclasses.dataclass(frozen=True)
class PlateFit:
    """The plate's point pairs and the error models fitted to them, per axis (x, y).

    origin_mm : (2,) the reading of circle (0, 0); the models take readings relative to it.
    u_mm, v_mm : (n,) the readings relative to ``origin_mm``.
    err_um : (n, 2) true - reading at each circle, relative to circle (0, 0).
    cubic : the seed's cubic (Eq. 5-9) of each axis.
    cubic_std : (2, 10) its coefficients' 1-sigma: the points' scatter, and the alignment's
        angle error in the cross slopes (a1 of y, a2 of x), um / mm^k.
    best : the model of each axis that cross-validation chose (:func:`select_model`).
    cv_rms_um : each axis's cross-validated RMS of every candidate model, um.
    sigma_um : the points' own scatter: the larger of the best models' RMSE.
    phi_std_rad : the 1-sigma of the measured plate angle, from that scatter.
    """

    origin_mm: np.ndarray
    u_mm: np.ndarray
    v_mm: np.ndarray
    err_um: np.ndarray
    cubic: tuple[Polynomial, ...]
    cubic_std: np.ndarray
    best: tuple[Polynomial, ...]
    cv_rms_um: tuple[dict[str, float], ...]
    sigma_um: float
    phi_std_rad: float


def fit_plate(readings_mm: np.ndarray, nominal_mm: np.ndarray, baseline_mm: float) -> PlateFit:
    """The error models of both axes from the plate's point pairs.

    Parameters
    ----------
    readings_mm : (n, 2) the readings at which each circle is on the optical axis; circle
        (0, 0) first.
    nominal_mm : (n, 2) each circle's nominal position from circle (0, 0) in the machine's
        frame (the plate's grid turned by the measured phi), mm.
    baseline_mm : the distance between the two circles whose readings gave phi.

    Returns
    -------
    The :class:`PlateFit`.
    """
    origin = readings_mm[0]
    rel = readings_mm - origin  # readings relative to circle (0, 0)
    err_um = (nominal_mm - rel) * 1000  # true - reading
    u, v = rel[:, 0], rel[:, 1]
    cubic = [fit_polynomial(u, v, err_um[:, a], 3) for a in range(2)]
    selected = [select_model(u, v, err_um[:, a], along=a) for a in range(2)]
    best = [m for m, _ in selected]
    sigma_um = max(b.rmse for b in best)  # the points' own scatter, from the best model
    # phi from two circles baseline_mm apart, each read to sigma_um along the other axis
    sigma_phi = np.sqrt(2) * sigma_um / 1000 / baseline_mm
    stds = []
    for a in range(2):
        std = cubic[a].coef_std(u, v, sigma_um)
        # circle (0, 0)'s reading is every point's datum: its own error shifts them all alike,
        # which the points' independent scatter does not hold; it enters the constant whole
        std[0] = np.hypot(std[0], sigma_um)
        # the alignment's own error turns the reference frame: it enters the cross slopes
        slope = 2 if a == 0 else 1
        std[slope] = np.hypot(std[slope], sigma_phi * 1000)
        stds.append(std)
    return PlateFit(
        origin_mm=origin,
        u_mm=u,
        v_mm=v,
        err_um=err_um,
        cubic=tuple(cubic),
        cubic_std=np.array(stds),
        best=tuple(best),
        cv_rms_um=tuple(s for _, s in selected),
        sigma_um=sigma_um,
        phi_std_rad=float(sigma_phi),
    )


def compensation_models(
    fit: PlateFit, rulers: Sequence[LineRuler]
) -> dict[str, Callable[[np.ndarray], np.ndarray]]:
    """The compensations side by side, each readings (n, 2) mm -> error (n, 2) um.

    Parameters
    ----------
    fit : the plate's models (:func:`fit_plate`).
    rulers : the line rulers along X and along Y (Eq. 3-4).

    Returns
    -------
    ``uncompensated`` (zero), ``lineruler``, ``polynomial`` (the cubic) and ``best`` (the model
    cross-validation chose).
    """
    cubic, best, origin = fit.cubic, fit.best, fit.origin_mm
    return {
        "uncompensated": lambda r: np.zeros_like(r),
        "lineruler": lambda r: np.stack([rulers[0](r[:, 0]), rulers[1](r[:, 1])], axis=1),
        "polynomial": lambda r: np.stack([cubic[a](*(r - origin).T) for a in range(2)], axis=1),
        "best": lambda r: np.stack([best[a](*(r - origin).T) for a in range(2)], axis=1),
    }
