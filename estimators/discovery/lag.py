"""A logged temperature seen through a first-order lag: a scale or a reference whose own
temperature follows the air with time constant ``lag_s`` (a heat capacity behind a surface).

    T_lag' = (T_air - T_lag) / lag_s
    thermal_expansion:  e = k (T_lag - mean T_lag) u      (k ppm/K, u the axis's position)
    thermal_drift:      e = c (T_lag - mean T_lag)        (c mm/K)

The time constant is searched on the rows the term is fitted to (:meth:`LagSearch.fix`) over a
log grid from a minute (a scanner's: seconds) to the recording's length, then finely between the
best's neighbours.
Its std is the larger of two approximations, each short where the other holds: the profile's
1-sigma interval widened as the fit's covariance (robust to drifting and heavy-tailed readings)
widens the coefficient's beside white noise's, and the fit's linearised about the time constant
(Gauss-Newton's: the term's column and its derivative in the time constant, times the
coefficient, fitted beside the rest, the covariance robust to a slow drift,
:func:`robust.long_run_cov`). On the second suite's lagged scales the first alone covered 0.84
(0.45 under drifting readings: the derivative changes more slowly in time than the column, and
a drift takes more of it), the larger 0.91; on a part's temperature integrated in time under a
faster drift (``tests/estimators/test_discovery_lag.py``) the second alone covered 0.875 with
an RMS of z of 2.0, the larger 0.90 and 1.5. The coefficient's std takes the time constant's
in, through how the coefficient moves along the profile:

    var k = var k | lag + (dk / dlag)^2 var lag

A time constant at either end of the grid is a bound, not an estimate: its std is itself.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from calibench.estimators.discovery.confounds import MIN_TEMPERATURE_SPAN_K
from calibench.estimators.discovery.effect import Drivers, Effect, coef_std
from calibench.estimators.discovery.fit import lstsq
from calibench.estimators.discovery.motion import lagged
from calibench.estimators.discovery.robust import long_run_cov, wider
from calibench.estimators.discovery.search import (
    profile,
    profile_coefficients,
    within_one_sigma,
)

LAG_GRID = 40  # time constants tried, log-spaced
FINE_GRID = 21  # then between the best's neighbours, evenly
SHORTEST_LAG_S = 60.0


@dataclasses.dataclass(frozen=True)
class LaggedThermal(Effect):
    """``thermal_expansion`` (``drift`` False) or ``thermal_drift`` of an axis following the
    logged temperature through a lag of ``lag_s`` (std ``lag_std_s``)."""

    name: str = "thermal_expansion"
    lag_s: float = 0.0
    lag_std_s: float = 0.0
    white_std: float = 0.0  # the coefficient's std at this lag under the profile's white noise
    coef_per_lag: float = 0.0  # d coefficient / d lag_s along the profile
    gn_std_s: float = 0.0  # the linearised fit's, robust to a drift (all rows' fits only)

    def __post_init__(self):
        object.__setattr__(self, "needs", ("temp_c", "t_s", self.axis))

    @property
    def key(self) -> str:
        """Beside the unlagged term of the same name and axis."""
        return f"{self.name}:{self.axis}:lagged"

    def columns(self, d: Drivers) -> np.ndarray:
        return _column(d, self.axis, self.name, self.lag_s)[:, None]

    def describe(self, coef, cov):
        k = float(coef[0])
        lag = {"lag_s": self.lag_s}
        # the fit's covariance against white noise's: the profile's interval widens alike
        widen = max(coef_std(cov, 0) / self.white_std, 1.0) if self.white_std > 0 else 1.0
        # the larger of the profile's, widened as the coefficient's is, and the linearised
        # fit's (where the term was fixed on all rows: the description's)
        lag_std = max(self.lag_std_s * widen, self.gn_std_s)
        k_std = float(np.hypot(coef_std(cov, 0), self.coef_per_lag * lag_std))
        if self.name == "thermal_expansion":
            params, std = {"ppm_per_k": k, **lag}, {"ppm_per_k": k_std}
            said = f"the {self.axis.upper()} scale grows {k:.2f} ppm per kelvin"
        else:
            params, std = {"mm_per_k": k, **lag}, {"mm_per_k": k_std}
            # a stage's axis, or another instrument's one reading (a scanner's radius)
            what = (
                f"whole {self.axis.upper()} axis" if self.axis in "xy" else f"{self.axis} reading"
            )
            said = f"the {what} shifts {k * 1000:+.2f} um per kelvin"
        return (
            params,
            {**std, "lag_s": lag_std},
            f"{said} of a temperature that follows the logged air {self.lag_s:.0f} s behind "
            f"(+- {lag_std:.0f} s): a part with a heat capacity of its own",
        )


def _column(d: Drivers, axis: str, name: str, lag_s: float) -> np.ndarray:
    """The term's column (n,) at one time constant."""
    t = np.asarray(d["t_s"], float)
    order = np.argsort(t, kind="stable")  # the lag runs in time, whatever the rows' order
    T = np.empty(len(t))
    T[order] = lagged(np.asarray(d["temp_c"], float)[order], t[order], lag_s)
    T = T - T.mean()
    return T * np.asarray(d[axis], float) * 1e-6 if name == "thermal_expansion" else T


@dataclasses.dataclass(frozen=True)
class LagSearch:
    """A lagged thermal term whose time constant is found on the rows it is fitted to."""

    axis: str
    name: str = "thermal_expansion"
    # the grid's shortest time constant: a stage's scale lags by minutes, a scanner's probe
    # mount, over a recording of a minute or two, by seconds
    shortest_s: float = SHORTEST_LAG_S

    @property
    def key(self) -> str:
        """As the term it fixes."""
        return LaggedThermal(name=self.name, axis=self.axis).key

    def applies(self, drivers: Drivers) -> bool:
        """A logged temperature that moves by a kelvin or more, with its times: a lag of a
        temperature that barely moves is any slow drift in time, whatever the air did."""
        T, t = drivers.get("temp_c"), drivers.get("t_s")
        return (
            T is not None
            and t is not None
            and np.ptp(np.asarray(T, float)) >= MIN_TEMPERATURE_SPAN_K
            and np.ptp(np.asarray(t, float)) > self.shortest_s
        )

    def fix(
        self, r: np.ndarray, others: np.ndarray, rows: np.ndarray, drivers: Drivers
    ) -> LaggedThermal:
        """The time constant whose term cuts ``r`` (m,) most beside ``others`` on ``rows``."""
        t = np.asarray(drivers["t_s"], float)
        coarse = np.geomspace(self.shortest_s, np.ptp(t), LAG_GRID)
        C = self._columns(drivers, coarse)
        best, _, _ = profile(r[rows], others[rows], C[rows])
        # refined between the best's neighbours, the profile read on both grids together
        lo, hi = coarse[max(best - 1, 0)], coarse[min(best + 1, LAG_GRID - 1)]
        fine = np.linspace(lo, hi, FINE_GRID)[1:-1]
        grid = np.r_[coarse, fine]
        order = np.argsort(grid, kind="stable")
        grid, C = grid[order], np.c_[C, self._columns(drivers, fine)][:, order]
        best, rss, sigma2 = profile(r[rows], others[rows], C[rows])
        coef, power = profile_coefficients(r[rows], others[rows], C[rows])
        lo_i, hi_i = max(best - 1, 0), min(best + 1, len(grid) - 1)
        std = max(within_one_sigma(grid, rss, best, sigma2), (grid[hi_i] - grid[lo_i]) / 2)
        if grid[best] in (coarse[0], coarse[-1]):  # at an end, a bound: as large as itself
            std = max(std, float(grid[best]))
        gn = self._linearised_std(r, others, drivers, float(grid[best])) if rows.all() else 0.0
        return LaggedThermal(
            name=self.name,
            axis=self.axis,
            lag_s=float(grid[best]),
            gn_std_s=gn,
            lag_std_s=std,
            white_std=float(np.sqrt(sigma2 / max(power[best], 1e-300))),
            coef_per_lag=float((coef[hi_i] - coef[lo_i]) / (grid[hi_i] - grid[lo_i])),
        )

    def _linearised_std(
        self, r: np.ndarray, others: np.ndarray, drivers: Drivers, lag_s: float
    ) -> float:
        """The time constant's std from the fit linearised about ``lag_s``: the term's column
        and its derivative in the time constant (times the coefficient) beside ``others``, the
        covariance robust to a slow drift (:func:`robust.long_run_cov`)."""
        h = 1e-3 * lag_s
        C = self._columns(drivers, np.array([lag_s - h, lag_s, lag_s + h]))
        X = np.c_[others, C[:, 1]]
        k = lstsq(X, r)[-1]
        X = np.c_[X, k * (C[:, 2] - C[:, 0]) / (2 * h)]
        coef = lstsq(X, r)
        res = r - X @ coef
        s2 = float(res @ res / max(len(r) - X.shape[1], 1))
        classical = np.linalg.pinv(X.T @ X) * s2
        t = np.asarray(drivers["t_s"], float)
        sample = np.argsort(np.argsort(t, kind="stable"), kind="stable")
        cov = wider(classical, long_run_cov(X, res, sample, np.zeros((0, X.shape[1]))))
        return float(np.sqrt(max(cov[-1, -1], 0.0)))

    def _columns(self, drivers: Drivers, lags: np.ndarray) -> np.ndarray:
        """The term's columns (n, K) at the time constants ``lags`` (K,)."""
        return np.stack([_column(drivers, self.axis, self.name, tau) for tau in lags], axis=1)
