"""Candidate effects of a Stewart platform: what its twin may have left out.

The signal is the legs' readings (mm), recording minus the twin at the pose the tracker
measured, stacked pose by pose: row 6 k + i is leg i + 1 of pose k. The drivers (plain arrays):
``L`` (n, 6) the twin's hinge-to-hinge lengths (mm), ``J_geo`` (n, 6, 42) d(reading) /
d(r_i, B_i, l_i) (the seven hinge parameters of each leg, leg by leg), ``dir`` (n, 6) the way
each leg last moved, ``temp_c`` (n,), ``force`` (n, 6) each leg's axial force from the twin's
statics (N, positive in compression). Interface as in :mod:`estimators.effects`.
"""

from __future__ import annotations

import dataclasses
from typing import TypedDict

import numpy as np

from calibench.estimators.discovery.effect import (
    Drivers,
    Effect,
    amplitude,
    below_zero,
    coef_std,
    drift_vector,
)


class StewartDrivers(TypedDict, total=False):
    """What a platform's candidates see, pose by pose (n poses, 6 legs): the legs' lengths
    ``L`` (n, 6) mm, the hinge geometry's Jacobian ``J_geo`` (n, 6, 42), the legs' directions of
    travel ``dir`` (n, 6) or None, their axial forces ``force`` (n, 6) N from the twin's statics,
    ``temp_c`` and ``t_s`` (n,) or None, the tracker frame's columns ``frame`` (6 n, 6): d(reading)
    / d(turn, shift) of the frame the tracker's poses were registered in."""

    L: np.ndarray
    J_geo: np.ndarray
    dir: np.ndarray | None
    force: np.ndarray | None
    temp_c: np.ndarray | None
    t_s: np.ndarray | None
    frame: np.ndarray


AXIS = "legs"
HINGE_NAMES = tuple(
    f"{p}{i}" for i in range(1, 7) for p in ("rx", "ry", "rz", "Bx", "By", "Bz", "l")
)


def on_leg(values: np.ndarray, leg: int) -> np.ndarray:
    """(n, k) values on leg ``leg``'s rows of the stacked signal, zeros elsewhere: (6 n, k)."""
    values = np.asarray(values, float).reshape(len(values), -1)
    out = np.zeros((len(values), 6, values.shape[1]))
    out[:, leg - 1] = values
    return out.reshape(-1, values.shape[1])


@dataclasses.dataclass(frozen=True)
class LegEffect(Effect):
    """Base of the effects of one leg (1..6): keyed by it."""

    axis: str = AXIS
    leg: int = 1

    @property
    def key(self) -> str:
        """The effect's name and leg."""
        return f"{self.name}:leg{self.leg}"


@dataclasses.dataclass(frozen=True)
class HingeGeometry(Effect):
    """The hinges and initial lengths differ from the drawing: the 42 leg parameters."""

    name: str = "geometry"
    axis: str = AXIS

    def __post_init__(self):
        object.__setattr__(self, "needs", ("J_geo",))

    def columns(self, d):
        J = np.asarray(d["J_geo"], float)
        return J.reshape(-1, J.shape[2])

    def describe(self, coef, cov):
        params = {n: float(c) for n, c in zip(HINGE_NAMES, coef)}
        stderr = {n: coef_std(cov, i) for i, n in enumerate(HINGE_NAMES)}
        big = sorted(params, key=lambda n: -abs(params[n]))[:3]
        return (
            params,
            stderr,
            "the hinges and initial leg lengths differ from the drawing (largest: "
            + ", ".join(f"{n} {params[n] * 1000:+.0f} um" for n in big)
            + "; the base hinges only up to the "
            "tracker's frame)",
        )


@dataclasses.dataclass(frozen=True)
class LegThermal(LegEffect):
    """The leg grows k (T - T_mean) of its length while its sensor measures the screw alone: the
    reading comes out short by that."""

    name: str = "thermal_expansion"

    def __post_init__(self):
        object.__setattr__(self, "needs", ("L", "temp_c"))

    def columns(self, d):
        T = np.asarray(d["temp_c"], float)
        return on_leg(-(T - T.mean()) * np.asarray(d["L"], float)[:, self.leg - 1] * 1e-6, self.leg)

    def describe(self, coef, cov):
        k = float(coef[0])
        return (
            {"leg": self.leg, "ppm_per_k": k},
            {"ppm_per_k": coef_std(cov, 0)},
            f"leg {self.leg} grows {k:.1f} ppm per kelvin of the logged temperature that its "
            f"length sensor does not see",
        )


@dataclasses.dataclass(frozen=True)
class LegDrift(LegEffect):
    """The leg's reading drifts with time (mm/h), wherever the leg is: its length sensor's zero
    (a read head warming, a scale's mount creeping). Offered when the recording carries ``t_s``;
    a drift that follows the logged temperature is the leg's ``thermal_expansion`` (nearly one
    column with this one when the temperature follows time and the legs barely change length)."""

    name: str = "thermal_drift"

    def __post_init__(self):
        object.__setattr__(self, "needs", ("t_s",))

    def applies(self, drivers):
        t = drivers.get("t_s")
        return t is not None and np.ptp(np.asarray(t, float)) > 0

    def columns(self, d):
        t = np.asarray(d["t_s"], float) / 3600
        t = t - t.mean()
        # a slope and a bend: a zero that settles (a warm-up) is no straight line in time
        return on_leg(np.stack([t, t**2 - np.mean(t**2)], axis=1), self.leg)

    def describe(self, coef, cov):
        k, bend = float(coef[0]), float(coef[1])
        return (
            {"leg": self.leg, "mm_per_h": k, "mm_per_h2": bend},
            {"mm_per_h": coef_std(cov, 0), "mm_per_h2": coef_std(cov, 1)},
            f"leg {self.leg}'s reading drifts {k * 1000:+.2f} um per hour at mid-recording "
            f"({bend * 1000:+.2f} um per hour squared) wherever the leg is: its length sensor's "
            "zero moves (a read head warming up, a scale's mount creeping)",
        )


@dataclasses.dataclass(frozen=True)
class LegBacklash(LegEffect):
    """Lost motion of the leg's drive on reversal: the reading +B/2 after extending, -B/2 after
    retracting."""

    name: str = "backlash"

    def __post_init__(self):
        object.__setattr__(self, "needs", ("dir",))

    def applies(self, drivers):
        d = drivers.get("dir")
        return d is not None and np.ptp(np.asarray(d)[:, self.leg - 1]) > 0

    def columns(self, d):
        return on_leg(np.asarray(d["dir"], float)[:, self.leg - 1] / 2, self.leg)

    def describe(self, coef, cov):
        B = float(coef[0])
        return (
            {"leg": self.leg, "reversal_mm": B},
            {"reversal_mm": coef_std(cov, 0)},
            f"leg {self.leg}'s drive loses {B * 1000:+.1f} um on reversal (its nut or coupling's "
            "backlash)",
        )


@dataclasses.dataclass(frozen=True)
class LegPitch(LegEffect):
    """The leg's screw's pitch error: periodic in its length, ``period_mm`` the screw's lead."""

    name: str = "periodic"
    period_mm: float = 5.0
    period_std: float | None = None

    def __post_init__(self):
        object.__setattr__(self, "needs", ("L",))

    def columns(self, d):
        ph = 2 * np.pi * np.asarray(d["L"], float)[:, self.leg - 1] / self.period_mm
        return on_leg(np.stack([np.sin(ph), np.cos(ph)], axis=1), self.leg)

    def describe(self, coef, cov):
        amp, amp_std, phase = amplitude(*coef, cov)
        return (
            {"leg": self.leg, "period_mm": self.period_mm, "amplitude_mm": amp, "phase_rad": phase},
            {"period_mm": self.period_std, "amplitude_mm": amp_std},
            f"leg {self.leg} reads {amp * 1000:.1f} um off once every {self.period_mm:.2f} mm of "
            f"its length: its screw's periodic pitch error",
        )


@dataclasses.dataclass(frozen=True)
class LegPitchSearch:
    """A pitch error whose period is found on the rows it is fitted to (``periods`` (m,) mm)."""

    leg: int
    periods: np.ndarray
    axis: str = AXIS
    name: str = "periodic"

    @property
    def key(self) -> str:
        """The search's name and leg."""
        return f"{self.name}:leg{self.leg}"

    def fix(
        self, r: np.ndarray, others: np.ndarray, rows: np.ndarray, drivers: Drivers
    ) -> LegPitch:
        """The period explaining most of ``r`` (6 n,) beside ``others`` on ``rows``, on this leg's
        rows; refined by golden section around the grid's best."""
        from calibench.estimators.discovery.harmonics import best_period, refine_period

        mine = np.zeros((len(r) // 6, 6), bool)
        mine[:, self.leg - 1] = True
        keep = mine.ravel() & rows
        base = others[keep]
        base = base[:, np.any(base != 0, axis=0)]
        u = np.asarray(drivers["L"], float)[:, self.leg - 1].repeat(6)[keep]
        P, _ = best_period(u, r[keep], base, self.periods)
        k = int(np.argmin(np.abs(self.periods - P)))
        step = (
            abs(self.periods[min(k + 1, len(self.periods) - 1)] - self.periods[max(k - 1, 0)]) / 2
        )
        P, P_std = refine_period(u, r[keep], base, P, rel=max(1.5 * step / P, 1e-3))
        return LegPitch(leg=self.leg, period_mm=P, period_std=P_std)


@dataclasses.dataclass(frozen=True)
class LegCompliance(Effect):
    """Legs shortened by their axial load, c um per N of the force the twin's statics put on
    each (``force`` (n, 6) N): the sensor reads the screw, the structure gives. ``leg`` 0: one c
    for all six (legs of one design), else that leg's own."""

    name: str = "leg_compliance"
    axis: str = AXIS
    leg: int = 0

    def __post_init__(self):
        object.__setattr__(self, "needs", ("force",))

    @property
    def key(self) -> str:
        """The effect's name and leg (all: one for the six)."""
        return f"{self.name}:{'all' if self.leg == 0 else f'leg{self.leg}'}"

    def applies(self, drivers):
        F = drivers.get("force")
        return F is not None and np.ptp(np.asarray(F)[:, max(self.leg - 1, 0)]) > 0

    def columns(self, d):
        F = np.asarray(d["force"], float) * 1e-3  # um per N -> mm
        return F.reshape(-1, 1) if self.leg == 0 else on_leg(F[:, self.leg - 1], self.leg)

    def describe(self, coef, cov):
        c = float(coef[0])
        who = "every leg" if self.leg == 0 else f"leg {self.leg}"
        stiff = f" (a stiffness of {1 / c:.3g} N/um)" if c > 0 else ""
        params = {"um_per_n": c} if self.leg == 0 else {"leg": self.leg, "um_per_n": c}
        return (
            params,
            {"um_per_n": coef_std(cov, 0)},
            f"{who} gives {c:.3g} um per N of the axial load the platform's weight puts on "
            f"it{stiff}",
        )

    def implausible(self, coef, cov):
        return below_zero(
            f"{'every leg' if self.leg == 0 else f'leg {self.leg}'}'s compliance",
            coef,
            cov,
            "um / N",
        )


@dataclasses.dataclass(frozen=True)
class TrackerDrift(Effect):
    """The tracker's poses drift as a whole, whatever the legs do: its stand warming or settling,
    or its distances read long as the air it measures through changes (a scale about the tracker,
    metres away, is a shift of the platform along its line of sight). The platform's measured
    position moves with the logged temperature (mm/K, ``driver`` ``temp_c``) or with time
    (``t_s``: mm/h at mid-recording and a bend in mm/h^2), about the registered frame."""

    name: str = "thermal_drift"
    axis: str = AXIS
    driver: str = "temp_c"

    def __post_init__(self):
        object.__setattr__(self, "needs", (self.driver, "frame"))

    @property
    def key(self) -> str:
        """One candidate per driver."""
        return f"thermal_drift:tracker:{self.driver}"

    def applies(self, drivers):
        v = drivers.get(self.driver)
        return v is not None and np.ptp(np.asarray(v, float)) > 0 and "frame" in drivers

    @property
    def unit(self) -> str:
        """The slope's unit: mm per kelvin (temperature) or mm per hour (time)."""
        return "mm_per_h" if self.driver == "t_s" else "mm_per_k"

    def columns(self, d):
        v = np.asarray(d[self.driver], float) / (3600 if self.driver == "t_s" else 1)
        v = v - v.mean()
        shapes = [v] if self.driver == "temp_c" else [v, v**2 - np.mean(v**2)]
        shift = np.asarray(d["frame"], float)[:, 3:6]  # d(reading) / d(the frame's shift)
        return np.hstack([np.repeat(s, 6)[:, None] * shift for s in shapes])

    def describe(self, coef, cov):
        # the coefficients shift the frame back onto the readings: the poses drifted the other way
        params, stderr, slope = drift_vector(coef, cov, self.unit, sign=-1.0)
        k = params[self.unit]
        per = "hour at mid-recording" if self.driver == "t_s" else "kelvin of the logged air"
        return (
            {"tracker": True, **params},
            stderr,
            f"the tracker's poses drift {k * 1000:.2f} um per {per} as a whole (x "
            f"{slope[0] * 1000:+.2f}, y {slope[1] * 1000:+.2f}, z {slope[2] * 1000:+.2f} um in the "
            "base frame), whatever the legs do: the tracker's stand moving, or its distances "
            "scaled by air it no longer compensates, not the platform",
        )


def stewart_candidates(drivers: Drivers) -> list:
    """Every Stewart candidate the recording's columns support."""
    from calibench.estimators.discovery.warmup import LegWarmupSearch  # it builds on LegEffect

    out: list[Effect | LegPitchSearch | LegWarmupSearch] = [HingeGeometry()]
    for leg in range(1, 7):
        out += [LegThermal(leg=leg), LegBacklash(leg=leg), LegDrift(leg=leg)]
        out.append(LegWarmupSearch(leg))
        L = np.asarray(drivers["L"], float)[:, leg - 1]
        span = float(np.ptp(L))
        if span > 10.0:  # periods from 2 mm to a third of the span, uniform in frequency
            f = np.arange(3 / span, 0.5, 1 / (5 * span))
            out.append(LegPitchSearch(leg, 1 / f))
    out += [LegCompliance(leg=0)] + [LegCompliance(leg=leg) for leg in range(1, 7)]
    out += [TrackerDrift(driver="temp_c"), TrackerDrift(driver="t_s")]
    return [c for c in out if not hasattr(c, "applies") or c.applies(drivers)]
