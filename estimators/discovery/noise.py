"""The noise of a recording from its repeats: repeatability and the correlation of successive
deviations."""

from __future__ import annotations

import dataclasses

import numpy as np

# repeats closer than this, relative to the readings, differ by the means' rounding alone
SCATTER_FLOOR = 1e-12


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


def repeatability(
    r: np.ndarray, station: np.ndarray, order: np.ndarray, block: np.ndarray | None = None
) -> Noise:
    """Pooled scatter about each station's mean (stations visited at least twice).

    Parameters
    ----------
    r : (n,) the residual.
    station : (n,) ids: what was commanded (readings of one station are repeats).
    order : (n,) the time order, for the lag-1 correlation.
    block : (n,) ids, optional
        Short stretches of time (a turn, a pass): each block's own offset is taken out beside the
        stations' means, so a drift from block to block is not counted as scatter (taken across
        blocks, the repeatability would contain the drift, and the drift would look like noise).

    Returns
    -------
    Noise
        ``sigma_mm`` None when fewer than 3 degrees of freedom are left, or when the repeats
        agree to the arithmetic's rounding (a read-out coarser than its scatter repeats itself
        exactly): there is then no scatter to judge a residual by.
    """
    ids, inv, counts = np.unique(station, return_inverse=True, return_counts=True)
    rep = counts[inv] >= 2
    dof = int(rep.sum() - np.sum(counts >= 2))
    dev = r - (np.bincount(inv, weights=r) / counts)[inv]
    if block is not None:
        b_inv = np.unique(block, return_inverse=True)[1].ravel()
        n_blocks = int(np.unique(b_inv[rep]).size) if rep.any() else 0
        dof -= max(n_blocks - 1, 0)
        # the two-way (station + block) means by alternating projections: exact for a balanced
        # design (every station once per block) after one sweep, a few for gaps
        for _ in range(10):
            n_b = np.bincount(b_inv[rep], minlength=b_inv.max() + 1)
            total = np.bincount(b_inv[rep], weights=dev[rep], minlength=b_inv.max() + 1)
            shift = total / np.maximum(n_b, 1)
            dev = dev - shift[b_inv]
            back = np.bincount(inv, weights=dev * rep, minlength=len(ids)) / counts
            dev = dev - back[inv]
            if np.abs(shift).max(initial=0.0) < 1e-15 and np.abs(back).max(initial=0.0) < 1e-15:
                break
    if dof < 3:
        return Noise(None, 0.0, 0)
    sigma = float(np.sqrt(dev[rep] @ dev[rep] / dof))
    if not sigma > SCATTER_FLOOR * np.abs(r[rep]).max():
        return Noise(None, 0.0, dof)
    idx = np.argsort(order)
    seq = dev[idx][rep[idx]]
    lag1 = float(np.corrcoef(seq[:-1], seq[1:])[0, 1]) if len(seq) > 3 else 0.0
    return Noise(sigma, lag1 if np.isfinite(lag1) else 0.0, dof)


GROSS_SIGMAS = 8.0  # no Gaussian reading gets this far (1 in 8e14); a gross one does


def gross_samples(res: np.ndarray, sample: np.ndarray) -> np.ndarray:
    """Samples holding a reading beyond :data:`GROSS_SIGMAS` robust standard deviations (1.4826
    times the median absolute residual) of the residual ``res`` (m,), ``sample`` (m,) each row's
    sample: gross readings (a bubble in the beam, a missed count), not noise. Returns (n,) bool
    over the samples 0 .. max(sample)."""
    scale = 1.4826 * np.median(np.abs(res - np.median(res)))
    bad = np.abs(res - np.median(res)) > GROSS_SIGMAS * max(scale, 1e-300)
    out = np.zeros(int(sample.max()) + 1 if len(sample) else 0, bool)
    out[sample[bad]] = True
    return out
