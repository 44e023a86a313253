"""Where a residual is structured: scores against each driver with permutation tests that keep a
recording's own structure, a reversal profile, a change point in time.
"""

from __future__ import annotations

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


def follows(
    r: np.ndarray,
    drivers: list[tuple[str, np.ndarray | None, bool]],
    passes: np.ndarray,
    rng: np.random.Generator,
    p_max: float = 0.01,
    score_min: float = 0.02,
    n_perm: int = 199,
) -> list[tuple[str, np.ndarray, float, float]]:
    """The drivers a residual follows: the pipeline's localisation, the same for every
    instrument that tests its residual against its drivers one by one.

    Parameters
    ----------
    r : (n,) the residual after the scene model.
    drivers : (name, values (n,) or None, time_like) each; absent or constant ones skipped.
    passes : (n,) the pass (or turn) of each row: what the null keeps (:func:`permutation_p`).
    rng : the permutations' generator, drawn from in ``drivers``' order.
    p_max, score_min : a driver is kept where its permutation p is at most ``p_max`` and its
        binned R^2 at least ``score_min``.

    Returns
    -------
    (name, values as floats (n,), score, p) for each driver kept, in ``drivers``' order.
    """
    out = []
    for name, v, time_like in drivers:
        if v is None or np.ptp(v) == 0:
            continue
        values = np.asarray(v, float)
        score, p = permutation_p(r, values, passes, time_like, rng, n_perm)
        if p <= p_max and score >= score_min:
            out.append((name, values, score, p))
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
