"""The candidate-effect protocol: physical terms a simulation may have left out, each with units.

One small interface, many small implementations (docs/formats.md's vocabulary). An effect is linear
in its coefficients once its shape is fixed: ``columns(drivers) -> (n, k)`` in the signal's unit
(mm), ``describe(coef, cov) -> (params, stderr, physics)``. Shapes with a nonlinear parameter (a
period) are fixed by :func:`best_period` on the data they are fitted to.

``drivers`` is a dict of arrays, typed per instrument (``StageDrivers``, ``ArmDrivers``,
``ScannerDrivers``, ``StewartDrivers`` beside each instrument's candidates): ``x``, ``y``
(commanded, mm), ``dir_x``, ``dir_y`` (+1 / -1 / 0), ``t_s``, ``temp_c``, ``run`` for stages; for an
N-joint arm ``q`` (n, N) rad, ``J`` (n, 3, 5 N + 3) the chain's parameter Jacobian, ``Jq`` (n, 3, N)
d(point) / d(q), ``tau`` (n, N) the joints' gravity torques (N m, from the twin), ``grow`` (5 N +
3,) the chain's lengths in the Jacobian's layout. A missing driver means the candidate does not
apply (``applies`` is False). Searched shapes (a transmission's harmonic) are fixed by their
``fix(r, others, rows, drivers)`` on the rows they are fitted to.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import Any

import numpy as np

# What the candidates see, row by row: a mapping of arrays, typed per instrument (a TypedDict,
# which is a Mapping, not a dict, to the type checker)
Drivers = Mapping[str, Any]


@dataclasses.dataclass(frozen=True)
class Effect:
    """Base: a name from the vocabulary, the signal it acts on (``axis``: x, y or xyz), the
    drivers it needs."""

    name: str = ""
    axis: str = "x"
    needs: tuple[str, ...] = ()

    @property
    def key(self) -> str:
        """A name that tells this candidate apart from the others of its kind (for
        de-duplication)."""
        return f"{self.name}:{self.axis}"

    def applies(self, drivers: Drivers) -> bool:
        """Whether the recording carries what this effect needs (its drivers: directions,
        temperatures, ...)."""
        return all(
            drivers.get(k) is not None and np.ptp(np.asarray(drivers[k], float)) > 0
            for k in self.needs
        )

    def columns(self, drivers: Drivers) -> np.ndarray:
        """The effect's design matrix on the recording's rows, (n, k): one column per
        parameter, in the signal's unit per parameter unit."""
        raise NotImplementedError

    def describe(self, coef: np.ndarray, cov: np.ndarray) -> tuple[dict, dict, str]:
        """The effect in words and physical units, from its fitted coefficients (k,): what
        discover prints."""
        raise NotImplementedError

    def implausible(self, coef: np.ndarray, cov: np.ndarray) -> str:
        """Why fitted coefficients (k,) lie outside the effect's physical range (a compliance
        below zero), or "" where they do not: such a fit is not accepted, whatever it cuts."""
        return ""


def below_zero(what: str, coef: np.ndarray, cov: np.ndarray, unit: str) -> str:
    """The words for a compliance fitted below zero (its first coefficient), or "": a part that
    pushes back harder the more it is loaded is another effect in a compliance's clothes."""
    c = float(coef[0])
    if c >= 0:
        return ""
    return (
        f"{what} fitted at {c:.3g} +- {coef_std(cov, 0):.2g} {unit}, below zero: a stiffness "
        "that pushes back harder the more it is loaded is outside its physical range"
    )


def coef_std(cov: np.ndarray, i: int) -> float:
    """The std of coefficient ``i`` from a covariance (k, k), a rounding-negative variance as 0."""
    return float(np.sqrt(max(cov[i, i], 0.0)))


def amplitude(s: float, c: float, cov: np.ndarray) -> tuple[float, float, float]:
    """Amplitude, its std (first order) and phase of s sin + c cos."""
    amp = float(np.hypot(s, c))
    g = np.array([s, c]) / max(amp, 1e-300)  # d amp / d (s, c)
    return amp, float(np.sqrt(max(g @ cov[:2, :2] @ g, 0.0))), float(np.arctan2(c, s))


def drift_vector(
    coef: np.ndarray, cov: np.ndarray, unit: str, sign: float = 1.0
) -> tuple[dict, dict, np.ndarray]:
    """A drift of a whole (points, poses) along x, y, z: its slope's norm and components, and
    with 6 coefficients a bend per axis (``mm_per_h2``), each with its std.

    Args:
        coef: (3,) or (6,) the slope's x, y, z, then the bend's.
        cov: (k, k) their covariance.
        unit: the slope's unit (``mm_per_k``, ``mm_per_h``).
        sign: -1 where the coefficients are the correction, not the drift.

    Returns:
        params, stderr (dicts by name) and the slope (3,).
    """
    slope = sign * np.asarray(coef[:3], float)
    k = float(np.linalg.norm(slope))
    J = slope / k if k > 0 else np.zeros(3)  # d|slope| / d(slope): the sign squares out
    params = {unit: k, **{f"{a}_{unit}": float(c) for a, c in zip("xyz", slope)}}
    stderr = {unit: float(np.sqrt(max(J @ cov[:3, :3] @ J, 0.0)))}
    stderr |= {f"{a}_{unit}": coef_std(cov, i) for i, a in enumerate("xyz")}
    if len(coef) >= 6:
        params |= {f"{a}_mm_per_h2": sign * float(c) for a, c in zip("xyz", coef[3:6])}
        stderr |= {f"{a}_mm_per_h2": coef_std(cov, 3 + i) for i, a in enumerate("xyz")}
    return params, stderr, slope
