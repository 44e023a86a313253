"""Where a residual is structured: scores against each driver with permutation tests that keep a
recording's own structure, a reversal profile, a change point in time.
"""

from __future__ import annotations

import dataclasses

import numpy as np


# --- localisation --------------------------------------------------------------------------------
def binned_r2(r: np.ndarray, v: np.ndarray, bins: int = 8) -> float:
    """Fraction of r's variance explained by the means of r in quantile bins of v (or by its
    distinct values when there are few: a direction, a pass)."""
    vals = np.unique(v)
    if len(vals) <= bins:
        idx = np.searchsorted(vals, v)
    else:
        edges = np.quantile(v, np.linspace(0, 1, bins + 1)[1:-1])
        idx = np.searchsorted(edges, v)
    counts = np.bincount(idx)
    means = np.bincount(idx, weights=r) / np.maximum(counts, 1)
    tot = np.sum((r - r.mean()) ** 2)
    return float(np.sum(counts * (means - r.mean()) ** 2) / tot) if tot > 0 else 0.0


def permutation_p(r, v, passes, time_like: bool, rng, n_perm: int = 199) -> tuple[float, float]:
    """Score (binned R^2) of r against v and its p-value under a null that keeps each pass's
    own structure: whole passes permuted for a time-like driver, each pass's residuals shifted
    cyclically for a position-like one."""
    score = binned_r2(r, v)
    ids = np.unique(passes)
    blocks = [np.flatnonzero(passes == p) for p in ids]
    hits = 0
    for _ in range(n_perm):
        rp = np.empty_like(r)
        if time_like and len(blocks) > 2:
            perm = rng.permutation(len(blocks))
            vp = np.empty_like(v)
            for b, pb in zip(blocks, perm):
                src = blocks[pb]
                vp[b] = np.interp(np.linspace(0, 1, len(b)), np.linspace(0, 1, len(src)), v[src])
            hits += binned_r2(r, vp) >= score
        else:
            for b in blocks:
                rp[b] = np.roll(r[b], rng.integers(1, max(len(b), 2)))
            hits += binned_r2(rp, v) >= score
    return score, (hits + 1) / (n_perm + 1)


# how a driver's null keeps the recording's own structure (:class:`Driver`)
NULLS = ("shift", "passes", "shuffle", "along")


@dataclasses.dataclass(frozen=True)
class Driver:
    """A driver a residual is tested against: its name, its values (n,) (None: not recorded) and
    the null that keeps what the recording's order would otherwise fake.

    - ``shift``: each pass's residual shifted cyclically (a position along a path: a drift keeps
      its shape and cannot pass for the position);
    - ``passes``: whole passes permuted (time, temperature: a pass's slow change is not spread);
    - ``shuffle``: the values permuted (rows recorded in random order: time itself is tested);
    - ``along``: the correlation of neighbours in the driver's order, residuals shifted in time as
      the null (a short period along the driver, which binned means would average out).
    """

    name: str
    values: np.ndarray | None
    null: str = "shift"
    # what the residual is taken beyond: its means in quantile bins of these values are removed
    # before the test (a direction of last motion beyond the angle it came to, which random
    # postures tie it to)
    given: np.ndarray | None = None

    def __post_init__(self):
        if self.null not in NULLS:
            raise ValueError(f"unknown null {self.null!r} (known: {', '.join(NULLS)})")


@dataclasses.dataclass(frozen=True)
class Followed:
    """A driver a residual follows: its values as floats (n,), the score (binned R^2, or the
    neighbours' correlation for ``along``), the permutation p-value and the residual's column
    that scored it (0 for one residual)."""

    name: str
    values: np.ndarray
    score: float
    p: float
    column: int = 0


def along(r: np.ndarray, v: np.ndarray) -> float:
    """How much r is a function of v at any scale: the correlation of r's neighbours in v's
    order (a screw's pitch error of a few mm shows here where binned means would average it out)."""
    a = r[np.argsort(v, kind="stable")]
    a = a - a.mean()
    den = np.sqrt(np.sum(a[:-1] ** 2) * np.sum(a[1:] ** 2))
    return float(np.sum(a[:-1] * a[1:]) / den) if den > 0 else 0.0


def _score_and_p(r, d: Driver, v, passes, rng, n_perm) -> tuple[float, float]:
    """The score of ``r`` against ``v`` and its p-value under ``d``'s null."""
    if d.null in ("shift", "passes"):
        return permutation_p(r, v, passes, d.null == "passes", rng, n_perm)
    if d.null == "shuffle":
        score = binned_r2(r, v)
        hits = sum(binned_r2(r, rng.permutation(v)) >= score for _ in range(n_perm))
    else:
        score = along(r, v)
        hits = sum(along(np.roll(r, rng.integers(1, len(r))), v) >= score for _ in range(n_perm))
    return score, (hits + 1) / (n_perm + 1)


def _beyond(r: np.ndarray, given: np.ndarray, bins: int = 8) -> np.ndarray:
    """``r`` (n, k) less its means in quantile bins of ``given`` (n,)."""
    edges = np.quantile(given, np.linspace(0, 1, bins + 1)[1:-1])
    idx = np.searchsorted(edges, given)
    counts = np.bincount(idx, minlength=bins)[:, None]
    means = np.stack([np.bincount(idx, weights=c, minlength=bins) for c in r.T], axis=1)
    return r - (means / np.maximum(counts, 1))[idx]


def follows(
    r: np.ndarray,
    drivers: list[Driver],
    passes: np.ndarray,
    rng: np.random.Generator,
    p_max: float = 0.01,
    score_min: float = 0.02,
    n_perm: int = 199,
) -> list[Followed]:
    """The drivers a residual follows: the pipeline's localisation, the same for every
    instrument, which only says which drivers it has and, in words, where.

    Parameters
    ----------
    r : (n,) the residual after the scene model, or (n, k) k residuals of each row (a point's
        coordinates): a driver is scored on each, the best kept.
    drivers : each with its null (:class:`Driver`); absent or constant ones skipped.
    passes : (n,) the pass (or turn) of each row: what the ``shift`` and ``passes`` nulls keep.
    rng : the permutations' generator, drawn from in ``drivers``' order (then the columns').
    p_max, score_min : a driver is kept where its p is at most ``p_max`` and its score at least
        ``score_min``.

    Returns
    -------
    A :class:`Followed` for each driver kept, in ``drivers``' order.
    """
    columns = np.asarray(r, float).reshape(len(r), -1)
    out = []
    for d in drivers:
        if d.values is None or np.ptp(d.values) == 0:
            continue
        values = np.asarray(d.values, float)
        cols = columns if d.given is None else _beyond(columns, np.asarray(d.given, float))
        tried = [
            _score_and_p(cols[:, k], d, values, passes, rng, n_perm) + (k,)
            for k in range(cols.shape[1])
        ]
        score, p, k = max(tried, key=lambda s: s[0])
        if p <= p_max and score >= score_min:
            out.append(Followed(d.name, values, score, p, k))
    return out


def reversal_profile(r, u, direction, bins: int = 10) -> tuple[np.ndarray, np.ndarray]:
    """Forward-minus-backward mean residual in bins of position: (centres (k,), profile (k,))."""
    edges = np.linspace(u.min(), u.max(), bins + 1)
    idx = np.clip(np.searchsorted(edges, u, side="right") - 1, 0, bins - 1)
    prof = np.full(bins, np.nan)
    for k in range(bins):
        f, b = r[(idx == k) & (direction > 0)], r[(idx == k) & (direction < 0)]
        if len(f) and len(b):
            prof[k] = f.mean() - b.mean()
    return (edges[:-1] + edges[1:]) / 2, prof


def change_point(r_time_ordered: np.ndarray) -> tuple[int, float]:
    """CUSUM: the index of the largest shift in mean and its statistic, max |S| / (sigma sqrt n)."""
    x = r_time_ordered - r_time_ordered.mean()
    S = np.cumsum(x)
    k = int(np.argmax(np.abs(S[:-1])))
    sd = np.std(np.diff(r_time_ordered)) / np.sqrt(2) + 1e-300
    return k, float(np.abs(S[k]) / (sd * np.sqrt(len(x))))


def where_text(v: np.ndarray, label: str) -> str:
    """The span of values ``v`` in words: "``label`` lo-hi mm" (or "= value" when they are all
    one)."""
    lo, hi = float(np.min(v)), float(np.max(v))
    return f"{label} {lo:.0f}-{hi:.0f} mm" if hi > lo else f"{label} = {lo:.0f} mm"
