"""The rail's calibration: offset, scale and lost motion by least squares (numpy only, as an
estimator of ``estimators/`` is: it sees the recording's arrays, never the twin)."""

from __future__ import annotations

import dataclasses

import numpy as np


@dataclasses.dataclass(frozen=True)
class RailFit:
    """The rail's error model fitted to its readings: ``x_meas - x_cmd = offset + scale x_cmd -
    dir lost_motion / 2``.

    Attributes
    ----------
    offset_um : float
        The reading at the command 0, midway between the two directions, um.
    scale_ppm : float
        The reading's growth per commanded length beyond 1, ppm.
    lost_motion_um : float
        The reading approached backward minus approached forward, um (positive: the carriage
        lags the screw in the direction of motion).
    std : dict of str to float
        Each parameter's 1-sigma from the residual scatter, in its unit.
    unit_std : dict of str to float
        Each parameter's 1-sigma per um of reading noise: the design's alone (its std for a
        stated noise sigma_um is sigma_um times this).
    rms_um : float
        The residual's RMS, um.
    """

    offset_um: float
    scale_ppm: float
    lost_motion_um: float
    std: dict
    unit_std: dict
    rms_um: float


NAMES = ("offset_um", "scale_ppm", "lost_motion_um")


def fit_rail(x_cmd_mm: np.ndarray, x_meas_mm: np.ndarray, dir_x: np.ndarray) -> RailFit:
    """Least squares of the rail's error model.

    Parameters
    ----------
    x_cmd_mm : (n,) the commanded positions, mm.
    x_meas_mm : (n,) the measured positions, mm.
    dir_x : (n,) +1 / -1, the direction of each reading's approach.

    Returns
    -------
    RailFit
        The parameters, their std (residual scatter, n - 3 degrees of freedom) and the design's.

    Raises
    ------
    ValueError
        Fewer than 4 readings, or readings of one direction or one place only (the model is
        then not determined).
    """
    x, d = np.asarray(x_cmd_mm, float), np.asarray(dir_x, float)
    e_um = (np.asarray(x_meas_mm, float) - x) * 1000.0
    # um per (um, ppm, um): ppm times mm is 1e-3 um
    X = np.stack([np.ones_like(x), x * 1e-3, -d / 2], axis=1)
    if len(x) < 4 or np.linalg.matrix_rank(X) < 3:
        raise ValueError("the readings do not determine offset, scale and lost motion")
    coef, *_ = np.linalg.lstsq(X, e_um, rcond=None)
    res = e_um - X @ coef
    unit_cov = np.linalg.inv(X.T @ X)
    s2 = float(res @ res) / (len(x) - 3)
    unit = np.sqrt(np.diag(unit_cov))
    return RailFit(
        offset_um=float(coef[0]),
        scale_ppm=float(coef[1]),
        lost_motion_um=float(coef[2]),
        std={k: float(np.sqrt(s2) * u) for k, u in zip(NAMES, unit)},
        unit_std={k: float(u) for k, u in zip(NAMES, unit)},
        rms_um=float(np.sqrt(np.mean(res**2))),
    )
