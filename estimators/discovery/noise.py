"""The noise of a recording: the repeatability from its repeats (the fits' weights), the noise
floor from its fastest repeats (the verdict's yardstick), and gross readings.

The floor is the variogram's origin: half the mean squared difference of two readings of one
place taken as close in time as the recording has them,

    floor^2 = 1/2 mean (r_i - r_j)^2   over pairs (i, j) nearest in time,

taken over the repeats of a station at their shortest lags and, where the instrument's successive
readings are near-repeats (a path sampled finely), over successive readings; of the two, the one
whose 95 % upper bound is lower (a floor of few pairs is loose, whatever its value). Slow change
between passes (a temperature, a drift) cannot inflate it; structure that changes from one reading
to the next can, so it is an upper bound on the noise, never a lower.
"""

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


# the repeat pairs the floor is taken from: this fraction of them, the shortest in time (and at
# least MIN_PAIRS): the variogram's first lags, before slow change adds to them
SHORTEST_LAGS = 0.25
MIN_PAIRS = 10


@dataclasses.dataclass(frozen=True)
class Floor:
    """A recording's noise floor (1-sigma of one reading, mm; None: nothing to take it from),
    what it was taken from ("repeats at their shortest lags", "successive readings"), the number
    of pairs, and the residual's lag-1 correlation in time and along the path (its neighbours in
    position): near 1, the residual is slow structure, not noise."""

    sigma_mm: float | None
    source: str
    pairs: int
    lag1_time: float
    lag1_path: float

    @property
    def upper_mm(self) -> float | None:
        """The floor's one-sided 95 % upper bound: its pairs' half squared differences are a
        chi-square of ``pairs`` degrees of freedom (fewer where a station's pairs share a
        reading: then the bound is a little too tight). Few pairs, a loose bound."""
        from scipy.stats import chi2

        if self.sigma_mm is None or self.pairs < 1:
            return None
        return float(self.sigma_mm * np.sqrt(self.pairs / chi2.ppf(0.05, self.pairs)))


def _half_mean_square(d: np.ndarray) -> float:
    return float(np.mean(np.square(d)) / 2)


def _lag1(r: np.ndarray, same: np.ndarray) -> float:
    """Correlation of successive values of ``r`` where ``same`` (len(r) - 1,) says they belong
    together (one pass)."""
    a, b = r[:-1][same], r[1:][same]
    if len(a) < 4 or np.std(a) == 0 or np.std(b) == 0:
        return 0.0
    c = float(np.corrcoef(a, b)[0, 1])
    return c if np.isfinite(c) else 0.0


def noise_floor(
    r: np.ndarray,
    order: np.ndarray,
    station: np.ndarray | None = None,
    passes: np.ndarray | None = None,
    successive: bool = False,
    path: np.ndarray | None = None,
) -> Floor:
    """The noise floor of the residual ``r`` (n,) from its fastest repeats.

    Parameters
    ----------
    r : (n,) the residual (after the model whose leftovers are judged).
    order : (n,) the readings' order in time (seconds, or an index).
    station : (n,) ids of what was commanded (readings of one station are repeats), optional.
    passes : (n,) ids of the series a reading belongs to (a pass, a leg, a coordinate):
        successive readings are taken within one (a station's repeats may span several).
    successive : whether successive readings of a pass are near-repeats (a path sampled finely),
        so that their differences also bound the noise.
    path : (n,) the position along the path, for the lag-1 correlation along it (default:
        ``order``).

    Returns
    -------
    Floor
    """
    r = np.asarray(r, float)
    n = len(r)
    passes = np.zeros(n, int) if passes is None else np.asarray(passes)
    by_time = np.lexsort((np.asarray(order, float), passes))
    same = passes[by_time][1:] == passes[by_time][:-1]
    lag1_time = _lag1(r[by_time], same)
    by_path = np.lexsort((np.asarray(order if path is None else path, float), passes))
    lag1_path = _lag1(r[by_path], passes[by_path][1:] == passes[by_path][:-1])
    found: list[tuple[float, str, int]] = []
    if station is not None:
        keyed = np.lexsort((np.asarray(order, float), np.asarray(station)))
        st = np.asarray(station)[keyed]
        pair = st[1:] == st[:-1]
        if pair.sum() >= MIN_PAIRS:
            lag = np.diff(np.asarray(order, float)[keyed])[pair]
            d = np.diff(r[keyed])[pair]
            k = max(MIN_PAIRS, int(np.ceil(SHORTEST_LAGS * len(d))))
            shortest = np.argsort(lag, kind="stable")[:k]
            found.append((_half_mean_square(d[shortest]), "repeats at their shortest lags", k))
    if successive and same.sum() >= MIN_PAIRS:
        d = np.diff(r[by_time])[same]
        found.append((_half_mean_square(d), "successive readings", len(d)))
    if not found:
        return Floor(None, "", 0, lag1_time, lag1_path)
    floors = [Floor(float(np.sqrt(v)), s, k, lag1_time, lag1_path) for v, s, k in found]
    # the tightest bound on the noise: a floor of few pairs is loose, whatever its value
    return min(floors, key=lambda f: f.upper_mm or np.inf)


def pooled(floors: dict[str, Floor]) -> Floor | None:
    """One floor for several axes: the RMS of their sigma (each axis's readings alike in number),
    the sources and lag-1 correlations of the largest; None when no axis has one."""
    have = [f for f in floors.values() if f.sigma_mm is not None]
    if not have:
        return None
    top = max(have, key=lambda f: f.sigma_mm or 0.0)
    sigma = float(np.sqrt(np.mean([f.sigma_mm**2 for f in have if f.sigma_mm is not None])))
    return dataclasses.replace(top, sigma_mm=sigma, pairs=sum(f.pairs for f in have))


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


def resolution(values: np.ndarray) -> float:
    """The reading's resolution (its count) from the distinct values ``values`` (n,) takes, 0 for
    readings that are not quantised (gaps that are not whole multiples of the smallest).

    The count is the mean gap between neighbouring values where they lie dense (gaps up to 3
    times the median), so a count that a finer grid rounds again (counts of 7.4 um read by a
    5 um encoder: gaps of 5 and 10 um) is read as its own size. Where the readings leave levels
    empty (fewer readings than levels over their range) it is read larger than it is.

    A coarse count with little scatter before it makes an error that repeats at each place the
    instrument revisits (up to half a count), which repeats cannot tell from a local effect:
    only an effect beyond half a count is one of the machine's.
    """
    v = np.asarray(values, float)
    u = np.unique(v[np.isfinite(v)])
    if len(u) < 3:
        return 0.0
    gaps = np.diff(u)
    steps = gaps / gaps.min()
    if np.mean(np.abs(steps - np.round(steps)) < 1e-3) < 0.99:  # not on a grid
        return 0.0
    return float(np.mean(gaps[gaps <= 3 * np.median(gaps)]))
