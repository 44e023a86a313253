"""Candidate effects of a rotary probe scanner: what its twin may have left out.

The signal is the probe's reading, ``rho`` (mm): recording minus the calibrated twin. The
drivers (plain (n,) arrays): ``theta`` the table encoder's angle (rad), ``rho`` the twin's
reading at that angle (mm), ``drho`` its slope d rho / d theta (mm/rad, from the twin's model),
``turn`` the turn of each sample. Same interface as :mod:`estimators.effects`: ``columns``
(n, k), ``describe`` -> (params, stderr, physics); a searched shape has ``fix``.
"""

from __future__ import annotations

import dataclasses
from typing import TypedDict

import numpy as np

from calibench.estimators.discovery.effect import Drivers, Effect, amplitude, coef_std
from calibench.estimators.discovery.lag import LagSearch
from calibench.estimators.discovery.stage import ThermalDrift


class ScannerDrivers(TypedDict, total=False):
    """What a scanner's candidates see, sample by sample (n,): the table's angle ``theta``
    (rad), the twin's reading ``rho`` (mm) and its slope ``drho`` (mm / rad), the ``turn``,
    ``t_s`` and ``temp_c`` (or None)."""

    theta: np.ndarray
    rho: np.ndarray
    drho: np.ndarray
    turn: np.ndarray
    t_s: np.ndarray | None
    temp_c: np.ndarray | None


AXIS = "rho"
SHORTEST_MOUNT_LAG_S = 2.0  # a fifth of a turn: a shorter lag is the air itself


@dataclasses.dataclass(frozen=True)
class Runout(Effect):
    """The table's radial error motion at ``harmonic`` k per turn, along the rail (which turns
    with the table, so the sensitive direction turns too and the error is a function of the
    angle alone): e = a sin(k theta) + b cos(k theta), the reading short by e."""

    name: str = "runout"
    axis: str = AXIS
    harmonic: int = 2

    def __post_init__(self):
        object.__setattr__(self, "needs", ("theta",))

    @property
    def key(self) -> str:
        """One candidate per harmonic."""
        return f"runout:{self.harmonic}"

    def columns(self, d):
        h = self.harmonic * np.asarray(d["theta"], float)
        return np.stack([np.sin(h), np.cos(h)], axis=1)

    def describe(self, coef, cov):
        amp, amp_std, phase = amplitude(*coef, cov)
        return (
            {"harmonic": self.harmonic, "amplitude_mm": amp, "phase_rad": phase},
            {"amplitude_mm": amp_std},
            f"the rotary table runs out radially {amp * 1000:.1f} um {self.harmonic} times per "
            f"turn (its bearing's error motion, along the rail)",
        )


@dataclasses.dataclass(frozen=True)
class RunoutSearch:
    """A runout whose harmonic (a whole number per turn: the error motion repeats with the
    table) is found on the rows it is fitted to. ``rank`` tells the searches apart: the second
    finds the next harmonic beside the first."""

    harmonics: tuple[int, ...] = tuple(
        range(1, 31)
    )  # the caller leaves out what its artefact cannot show
    rank: int = 1
    axis: str = AXIS
    name: str = "runout"

    @property
    def key(self) -> str:
        """The search's name and rank."""
        return f"runout#{self.rank}"

    def fix(self, r: np.ndarray, others: np.ndarray, rows: np.ndarray, drivers: Drivers) -> Runout:
        """The harmonic explaining most of ``r`` beside ``others`` (n, p) on ``rows`` (n,) bool."""
        theta = np.asarray(drivers["theta"], float)[rows]
        Q = np.linalg.qr(others[rows])[0] if others.shape[1] else np.zeros((int(rows.sum()), 0))
        rr = r[rows] - Q @ (Q.T @ r[rows])
        best, best_k = -1.0, self.harmonics[0]
        for k in self.harmonics:
            X = np.stack([np.sin(k * theta), np.cos(k * theta)], axis=1)
            X -= Q @ (Q.T @ X)
            if np.linalg.matrix_rank(X, 1e-9 * max(np.abs(X).max(), 1e-300)) < 2:
                continue
            e = np.linalg.lstsq(X, rr, rcond=None)[0]
            gain = float(rr @ (X @ e))
            if gain > best:
                best, best_k = gain, k
        return Runout(harmonic=int(best_k))


@dataclasses.dataclass(frozen=True)
class TableEccentricity(Effect):
    """The table encoder's disc off-centre: it reads theta + A sin(theta + phase), so the
    reading belongs to an angle short by that, and the probe's reading is off by -rho' dtheta."""

    name: str = "encoder_eccentricity"
    axis: str = AXIS

    def __post_init__(self):
        object.__setattr__(self, "needs", ("theta", "drho"))

    def columns(self, d):
        th, slope = np.asarray(d["theta"], float), np.asarray(d["drho"], float)
        return -np.stack([slope * np.sin(th), slope * np.cos(th)], axis=1)

    def describe(self, coef, cov):
        amp, amp_std, phase = amplitude(*coef, cov)
        return (
            {"amplitude_urad": amp * 1e6, "phase_rad": phase},
            {"amplitude_urad": amp_std * 1e6},
            f"the table's encoder reads {amp * 1e6:.0f} urad off once per turn: its disc is "
            "mounted off-centre",
        )


@dataclasses.dataclass(frozen=True)
class ProbeScale(Effect):
    """The probe's scale: it reads (1 + s) times the true distance; s in ppm."""

    name: str = "scale"
    axis: str = AXIS

    def __post_init__(self):
        object.__setattr__(self, "needs", ("rho",))

    def columns(self, d):
        return (np.asarray(d["rho"], float) * 1e-6)[:, None]

    def describe(self, coef, cov):
        s = float(coef[0])
        return (
            {"ppm": s},
            {"ppm": coef_std(cov, 0)},
            f"the probe's linear encoder reads {s:+.0f} ppm long (its scale, or its lever's ratio)",
        )


@dataclasses.dataclass(frozen=True)
class ProbeOffset(Effect):
    """The probe's zero: a constant added to every reading (the rail's dL is the same column)."""

    name: str = "offset"
    axis: str = AXIS

    def columns(self, d):
        return np.ones((len(d["theta"]), 1))

    def describe(self, coef, cov):
        return (
            {"offset_mm": float(coef[0])},
            {"offset_mm": coef_std(cov, 0)},
            f"the probe's zero is {coef[0] * 1000:+.1f} um off",
        )


@dataclasses.dataclass(frozen=True)
class ProbeDrift(ThermalDrift):
    """The probe's zero drifting with the logged temperature (mm/K), or with time (mm/h) when no
    temperature is logged: the stages' drift (its columns and unit) on the probe's reading, so
    the same angle reads differently turn after turn. Held out by whole turns, a drift is
    predicted from the held-out turn's own temperature or time."""

    name: str = "thermal_drift"
    axis: str = AXIS
    driver: str = "temp_c"

    @property
    def key(self) -> str:
        """One candidate per driver."""
        return f"thermal_drift:{self.driver}"

    def describe(self, coef, cov):
        k = float(coef[0])
        per = "hour" if self.driver == "t_s" else "kelvin"
        return (
            {self.unit: k},
            {self.unit: coef_std(cov, 0)},
            f"the probe's zero drifts {k * 1000:+.2f} um per {per}: every angle reads "
            f"differently turn after turn (a thermal drift of the probe or its mount)",
        )


@dataclasses.dataclass(frozen=True)
class AngleTable(Effect):
    """``nonsmooth``: a free correction in each flagged band of the table's angle (a nick or a
    burr on the artefact's wall, dirt on the stylus's path), a lookup table, not a law.

    ``table_id`` (360 / ``bin_deg``,) the table's column of each band of the angle, -1 outside
    the flagged region: a law of the angle, so it carries to another recording of the artefact
    (its own samples, any of them set aside)."""

    name: str = "nonsmooth"
    axis: str = AXIS
    table_id: np.ndarray | None = None  # a default only because Effect's fields have defaults
    bin_deg: float = 1.0
    where: str = ""
    peak_deg: float = 0.0

    def __post_init__(self):
        object.__setattr__(self, "needs", ("theta",))

    @property
    def key(self) -> str:
        """One table."""
        return "nonsmooth:rho"

    @property
    def n(self) -> int:
        """The table's entries."""
        assert self.table_id is not None, "an AngleTable is built with its bands"
        return int(np.sum(self.table_id >= 0))

    def column_of(self, d) -> np.ndarray:
        """Each sample's column of the table, (n,), -1 outside the flagged region."""
        assert self.table_id is not None, "an AngleTable is built with its bands"
        n_bins = len(self.table_id)
        deg = np.degrees(np.mod(np.asarray(d["theta"], float), 2 * np.pi))
        return self.table_id[np.floor(deg / self.bin_deg).astype(int) % n_bins]

    def columns(self, d):
        band = self.column_of(d)
        X = np.zeros((len(band), self.n))
        ok = band >= 0
        X[np.flatnonzero(ok), band[ok]] = 1.0
        return X

    def describe(self, coef, cov):
        k = int(np.argmax(np.abs(coef)))
        return (
            {"where": self.where, "theta_deg": self.peak_deg, "peak_mm": float(coef[k])},
            {"peak_mm": coef_std(cov, k)},
            f"a local error of the reading {self.where} that no candidate effect has (a nick or "
            "burr on the "
            f"artefact's wall, dirt in the stylus's path): modelled as a correction table there",
        )


def scanner_candidates(
    symmetry: int = 4, top: int = 30, n_runout: int = 3, told_apart: tuple = ()
) -> list:
    """Every scanner candidate: runout searches over harmonics 1..``top`` except the multiples of
    the artefact's ``symmetry`` (a square's form error repeats four times a turn: a runout there
    cannot be told from it) not in ``told_apart`` (those recordings of the plate turned on the
    table separate), the encoder's eccentricity, the probe's scale and offset, its zero's
    drift with temperature or time, and with the logged temperature through a lag (where the
    recording logs them; ``nonsmooth`` is looked for after them, on what they leave)."""
    harmonics = tuple(k for k in range(1, top + 1) if k % symmetry or k in told_apart)
    return [RunoutSearch(harmonics=harmonics, rank=k) for k in range(1, n_runout + 1)] + [
        TableEccentricity(),
        ProbeScale(),
        ProbeOffset(),
        ProbeDrift(driver="temp_c"),
        ProbeDrift(driver="t_s"),
        # a mount with a heat capacity follows the logged air behind it
        LagSearch(axis=AXIS, name="thermal_drift", shortest_s=SHORTEST_MOUNT_LAG_S),
    ]
