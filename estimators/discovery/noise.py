"""The noise of a recording from its repeats: repeatability and the correlation of successive
deviations."""

from __future__ import annotations

import dataclasses

import numpy as np


# --- noise from repeats --------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class Noise:
    sigma_mm: float | None  # repeatability (1-sigma of one reading about its station's mean)
    lag1: float  # correlation of successive deviations within a pass
    dof: int

    @property
    def inflation(self) -> float:
        """Variance inflation of a mean of correlated deviations (AR(1))."""
        rho = min(max(self.lag1, 0.0), 0.9)
        return float(np.sqrt((1 + rho) / (1 - rho)))


def repeatability(r: np.ndarray, station: np.ndarray, order: np.ndarray) -> Noise:
    """Pooled scatter about each station's mean (stations visited at least twice); ``station``
    (n,) ids, ``order`` (n,) the time order for the lag-1 correlation."""
    ids, inv, counts = np.unique(station, return_inverse=True, return_counts=True)
    rep = counts[inv] >= 2
    if rep.sum() - np.sum(counts >= 2) < 3:
        return Noise(None, 0.0, 0)
    means = np.bincount(inv, weights=r) / counts
    dev = (r - means[inv])[rep]
    dof = int(rep.sum() - np.sum(counts >= 2))
    sigma = float(np.sqrt(dev @ dev / dof))
    seq = (r - means[inv])[np.argsort(order)][rep[np.argsort(order)]]
    lag1 = float(np.corrcoef(seq[:-1], seq[1:])[0, 1]) if len(seq) > 3 else 0.0
    return Noise(sigma, lag1 if np.isfinite(lag1) else 0.0, dof)
