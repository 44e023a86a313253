"""Candidate effects of a two-axis stage (belt-stage, vision-stage): what its twin may have left
out, along each axis (docs/formats.md's vocabulary).
"""

from __future__ import annotations

import dataclasses
from typing import TypedDict

import numpy as np

from calibench.estimators.discovery.effect import Drivers, Effect, amplitude, coef_std
from calibench.estimators.discovery.harmonics import best_period, grid_rel, refine_period


class StageDrivers(TypedDict, total=False):
    """What a stage's candidates see, row by row (n,): the commanded ``x``, ``y`` (mm), the
    direction of the last approach ``dir_x``, ``dir_y`` (+1, -1, 0 unknown), ``t_s`` (s),
    ``temp_c`` (deg C) and the pass ``run``; None where the recording does not carry it."""

    x: np.ndarray
    y: np.ndarray
    dir_x: np.ndarray | None
    dir_y: np.ndarray | None
    t_s: np.ndarray | None
    temp_c: np.ndarray | None
    run: np.ndarray | None


AXES = ("x", "y")
# a period refined in the final fit moves by a few of its std (0.2-0.4 % seen), not to another
# peak of the periodogram
REFINE_REL = 0.01


@dataclasses.dataclass(frozen=True)
class Backlash(Effect):
    """Lost motion on reversal: +B/2 approaching forward, -B/2 backward. With ``span_mm`` (the
    axis's measured range, lo and hi) B grows along the travel, ``B(u) = B0 + g u``, as an
    elastic drive's does (a belt whose free span lengthens with the position)."""

    name: str = "backlash"
    span_mm: tuple[float, float] | None = None

    def __post_init__(self):
        object.__setattr__(
            self, "needs", (f"dir_{self.axis}",) + ((self.axis,) if self.span_mm else ())
        )

    @property
    def key(self) -> str:
        return f"backlash:{self.axis}" + (":grows" if self.span_mm else "")

    def columns(self, d):
        half = np.asarray(d[f"dir_{self.axis}"], float) / 2
        if self.span_mm is None:
            return half[:, None]
        return np.stack([half, half * np.asarray(d[self.axis], float) / 1000], axis=1)

    def describe(self, coef, cov):
        a = self.axis.upper()
        if self.span_mm is None:
            B = float(coef[0])
            return (
                {"reversal_mm": B},
                {"reversal_mm": coef_std(cov, 0)},
                f"lost motion on reversal of the {a} drive: {B * 1000:+.1f} um between the two "
                f"directions of approach (+B/2 approaching forward, -B/2 backward)",
            )
        lo, hi = self.span_mm
        mid = np.array([1.0, (lo + hi) / 2000])  # B at the middle of the measured travel
        B0, g = float(coef[0]), float(coef[1])
        params = {
            "reversal_mm": float(mid @ coef[:2]),
            "reversal_at_home_mm": B0,
            "growth_mm_per_m": g,
            "reversal_at_start_mm": B0 + g * lo / 1000,
            "reversal_at_end_mm": B0 + g * hi / 1000,
        }
        stderr = {
            "reversal_mm": float(np.sqrt(max(mid @ cov[:2, :2] @ mid, 0.0))),
            "reversal_at_home_mm": coef_std(cov, 0),
            "growth_mm_per_m": coef_std(cov, 1),
        }
        return (
            params,
            stderr,
            f"lost motion on reversal of the {a} drive that grows along the travel: "
            f"{params['reversal_at_start_mm'] * 1000:.1f} um at {self.axis} = {lo:.0f} mm to "
            f"{params['reversal_at_end_mm'] * 1000:.1f} um at {self.axis} = {hi:.0f} mm "
            f"({g * 100:+.1f} um per 100 mm): an elastic drive (a belt whose free span lengthens "
            f"along the travel) against the carriage's friction",
        )


@dataclasses.dataclass(frozen=True)
class Periodic(Effect):
    """A sinusoid in the axis's own position: pulley run-out, belt tooth, lead screw."""

    name: str = "periodic"
    period_mm: float = 0.0
    period_std: float | None = None

    def __post_init__(self):
        object.__setattr__(self, "needs", (self.axis,))

    def columns(self, d):
        ph = 2 * np.pi * np.asarray(d[self.axis], float) / self.period_mm
        return np.stack([np.sin(ph), np.cos(ph)], axis=1)

    def refine(self, r: np.ndarray, others: np.ndarray, drivers: Drivers) -> Periodic:
        """The period refined near its own beside ``others`` (m, p), every other term of the
        final model: the search fixed it beside the terms accepted before it only."""
        u = np.asarray(drivers[self.axis], float)
        P, P_std = refine_period(u, r, others, self.period_mm, rel=REFINE_REL)
        return dataclasses.replace(self, period_mm=P, period_std=P_std)

    def describe(self, coef, cov):
        amp, amp_std, phase = amplitude(*coef, cov)
        params = {"period_mm": self.period_mm, "amplitude_mm": amp, "phase_rad": phase}
        stderr = {"period_mm": self.period_std, "amplitude_mm": amp_std}
        return (
            params,
            stderr,
            f"a once-per-{self.period_mm:.1f} mm error of the {self.axis.upper()} axis, "
            f"{amp * 1000:.1f} um "
            f"amplitude: something in the drive turns once every {self.period_mm:.1f} mm of "
            f"travel (a pulley's or screw's run-out, a belt's tooth pattern)",
        )


@dataclasses.dataclass(frozen=True)
class ThermalExpansion(Effect):
    """Scale proportional to the temperature change: e = k (T - T_mean) u, k in ppm/K."""

    name: str = "thermal_expansion"

    def __post_init__(self):
        object.__setattr__(self, "needs", (self.axis, "temp_c"))

    def columns(self, d):
        T = np.asarray(d["temp_c"], float)
        return ((T - T.mean()) * np.asarray(d[self.axis], float) * 1e-6)[:, None]

    def describe(self, coef, cov):
        k = float(coef[0])
        return (
            {"ppm_per_k": k},
            {"ppm_per_k": coef_std(cov, 0)},
            f"the {self.axis.upper()} scale (or its reference) grows {k:.2f} ppm per kelvin of "
            f"the logged temperature: thermal expansion the simulation does not have",
        )


@dataclasses.dataclass(frozen=True)
class ThermalDrift(Effect):
    """An offset that follows the temperature (mm/K), or time when no temperature is logged."""

    name: str = "thermal_drift"
    driver: str = "temp_c"

    def __post_init__(self):
        object.__setattr__(self, "needs", (self.driver,))

    def columns(self, d):
        v = np.asarray(d[self.driver], float)
        v = v / 3600 if self.driver == "t_s" else v
        return (v - v.mean())[:, None]

    @property
    def unit(self) -> str:
        """The unit of the drift's coefficient: mm per hour (driven by time) or mm per kelvin."""
        return "mm_per_h" if self.driver == "t_s" else "mm_per_k"

    def describe(self, coef, cov):
        k = float(coef[0])
        per = "hour" if self.driver == "t_s" else "kelvin"
        return (
            {self.unit: k},
            {self.unit: coef_std(cov, 0)},
            f"the whole {self.axis.upper()} axis shifts {k * 1000:+.2f} um per {per}, wherever it "
            f"is: a drift of the reference, not of the scale",
        )


@dataclasses.dataclass(frozen=True)
class Polynomial(Effect):
    """Smooth terms beyond the scene's own model: x^i y^j for each (i, j) in ``powers``.

    Named by what they mean for the signal's axis: terms in the signal's own position are a
    nonlinear ``positioning`` error, terms in the other axis's position only are that axis's
    ``straightness``, mixed terms are ``cross_coupling``.
    """

    name: str = "positioning"
    powers: tuple[tuple[int, int], ...] = ()

    def __post_init__(self):
        object.__setattr__(self, "needs", ("x", "y"))

    def columns(self, d):
        x, y = np.asarray(d["x"], float), np.asarray(d["y"], float)
        sx, sy = (
            max(np.ptp(x), 1e-9),
            max(np.ptp(y), 1e-9),
        )  # scaled: coefficients in mm at full travel
        return np.stack(
            [((x - x.min()) / sx) ** i * ((y - y.min()) / sy) ** j for i, j in self.powers], axis=1
        )

    def describe(self, coef, cov):
        params = {f"x{i}y{j}_mm": float(c) for (i, j), c in zip(self.powers, coef)}
        stderr = {f"x{i}y{j}_mm": coef_std(cov, k) for k, (i, j) in enumerate(self.powers)}
        what = {
            "positioning": f"the {self.axis.upper()} axis's positioning error bends more than the "
            f"scene's model allows along its own travel",
            "straightness": f"the {self.axis.upper()} reading follows the other axis's position "
            f"beyond the scene's model: that axis's travel is not straight",
            "cross_coupling": f"the {self.axis.upper()} error depends on both positions together "
            f"beyond the scene's model",
        }[self.name]
        return params, stderr, what + " (coefficients: mm at full travel)"


def polynomial_candidates(axis: str, degree: int) -> list[Polynomial]:
    """The next order of smooth terms above a scene model of total ``degree`` in (x, y)."""
    own, other = (0, 1) if axis == "x" else (1, 0)
    n = degree + 1
    terms: dict[str, list[tuple[int, int]]] = {
        "positioning": [],
        "straightness": [],
        "cross_coupling": [],
    }
    for k in (n, n + 1):
        for i in range(k + 1):
            p = (i, k - i)
            if p[other] == 0:
                terms["positioning"].append(p)
            elif p[own] == 0:
                terms["straightness"].append(p)
            elif k == n:
                terms["cross_coupling"].append(p)
    return [Polynomial(name=name, axis=axis, powers=tuple(pw)) for name, pw in terms.items() if pw]


def stage_candidates(drivers: Drivers) -> list[Effect]:
    """Every stage candidate that the recording's columns can support (periodic added by the
    caller once its period is found)."""
    out = []
    for a in AXES:
        out += [Backlash(axis=a), ThermalExpansion(axis=a), ThermalDrift(axis=a, driver="temp_c")]
        if drivers.get("temp_c") is None:
            out.append(ThermalDrift(axis=a, driver="t_s"))
    return [e for e in out if e.applies(drivers)]


@dataclasses.dataclass(frozen=True)
class PeriodSearch:
    """A periodic candidate whose period is found on the data it is fitted to."""

    axis: str
    periods: np.ndarray
    name: str = "periodic"
    periodic: bool = True  # must help along the whole travel (select's test), not in one stretch

    @property
    def key(self) -> str:
        """The search's name and axis: one search per axis."""
        return f"periodic:{self.axis}"

    def fix(
        self, r: np.ndarray, others: np.ndarray, rows: np.ndarray, drivers: Drivers
    ) -> Periodic:
        """The periodic term at the period that best explains ``r`` (m,) on ``rows`` (m,) bool
        beside ``others`` (m, p): the grid's best, refined (variable projection), with its std."""
        u = np.asarray(drivers[self.axis], float)
        P0, _ = best_period(u[rows], r[rows], others[rows], self.periods)
        P, P_std = refine_period(u[rows], r[rows], others[rows], P0, rel=grid_rel(self.periods, P0))
        return Periodic(axis=self.axis, period_mm=P, period_std=P_std)
