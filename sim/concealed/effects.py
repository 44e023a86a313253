"""The concealed effects more than one generator writes: their draws, their errors and their
records for the manifest.

Each draw takes the recording's generator and draws in a fixed order, so that a recording stays
the same bit for bit from its seed.
"""

from __future__ import annotations

import numpy as np


def effect(name: str, axis: str, **params: float) -> dict:
    """A concealed effect's record for the manifest: its candidate's name, the axis it is on
    and its parameters (in the order given)."""
    return {"name": name, "axis": axis, "params": params}


def draw_lost_motion_mm(rng: np.random.Generator) -> float:
    """A drive's lost motion on reversal, 5-15 um, in mm."""
    return rng.uniform(5, 15) / 1000


def lost_motion_mm(reversal_mm: float, direction: np.ndarray) -> np.ndarray:
    """The error (n,) mm of a drive that loses ``reversal_mm`` on reversal, moving in
    ``direction`` (n,) (+1 / -1): half of it either way."""
    return reversal_mm / 2 * direction


def draw_periodic(
    rng: np.random.Generator, period_mm: tuple[float, float], amplitude_um: tuple[float, float]
) -> tuple[float, float, float]:
    """A periodic error: its period (mm), amplitude (mm) and phase (rad), drawn uniformly in
    that order from ``period_mm`` and ``amplitude_um`` (um) and a whole turn."""
    return (
        rng.uniform(*period_mm),
        rng.uniform(*amplitude_um) / 1000,
        rng.uniform(0, 2 * np.pi),
    )


def periodic_mm(
    u_mm: np.ndarray, period_mm: float, amplitude_mm: float, phase_rad: float
) -> np.ndarray:
    """A periodic error (n,) mm along the position ``u_mm`` (n,)."""
    return amplitude_mm * np.sin(2 * np.pi * u_mm / period_mm + phase_rad)


def expansion_mm(
    ppm_per_k: float, temp_c: np.ndarray, reference_c: float, length_mm: np.ndarray
) -> np.ndarray:
    """How much (n,) mm a length ``length_mm`` (n,) grows at ``temp_c`` (n,) from the
    ``reference_c`` it is calibrated at, ``ppm_per_k`` per kelvin."""
    return ppm_per_k * 1e-6 * (temp_c - reference_c) * length_mm
