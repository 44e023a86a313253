"""Sim versus real: where residuals are structured, which candidate effects explain them.

The recipe (issue 8's research notes):

1. Noise from repeats: stations visited more than once (passes) give the repeatability and the
   lag-1 correlation of the deviations; residuals alone would not (they hold the very structure
   being looked for).
2. Localise: each residual against each driver with a permutation test that keeps the passes'
   own structure (whole-pass permutations for time-like drivers, per-pass cyclic shifts for
   position-like ones); a forward-minus-backward reversal profile; a periodogram against
   position; a CUSUM change point in time.
3. Select: forward selection among candidate effects by held-out (leave-one-pass-out, or
   blocked) cross-validation. A candidate is accepted only if it improves its axis's held-out
   RMS by a practical floor, its coefficients are well determined, and (for a periodic term) it
   helps along the whole travel. The floor is calibrated on null recordings (see
   ``benchmarks/discover.py``).
4. Structure no candidate explains is reported as ``nonsmooth`` with where it is, and modelled
   as a table of station corrections, not forced onto the nearest candidate.
5. Confounding: a candidate whose column the accepted model already nearly spans is reported
   with the experiment that would separate the two.

Residual arrays are in mm; drivers as in :mod:`estimators.effects`.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy import linalg, optimize

from calibench.estimators.effects import Periodic, best_period

FLOOR = 0.10  # practical floor: an effect must cut its axis's held-out RMS by 10 %
Z_MIN = 5.0  # and be at least 5 standard errors from zero
NONSMOOTH_Z = 4.5  # a station's mean residual this many of its std from zero is structure


@dataclasses.dataclass
class Signal:
    """One residual series: ``r`` (m,) = recording - simulation, ``base`` (m, p) the scene
    model's free columns (calibrated with the data), ``sample`` (m,) the sample of each row,
    ``u`` (m,) the position along the axis (periodogram), ``axis`` the effects' axis key."""

    name: str
    axis: str
    r: np.ndarray
    base: np.ndarray
    sample: np.ndarray
    u: np.ndarray | None = None


@dataclasses.dataclass(frozen=True)
class PeriodSearch:
    """A periodic candidate whose period is found on the data it is fitted to."""

    axis: str
    periods: np.ndarray
    name: str = "periodic"

    @property
    def key(self) -> str:
        """The search's name and axis: one search per axis."""
        return f"periodic:{self.axis}"


@dataclasses.dataclass(frozen=True)
class StationTable:
    """``nonsmooth``: a free correction at each of the flagged stations (a lookup table)."""

    axis: str
    station: np.ndarray  # (m,) station id of each row, -1 outside the region
    n: int
    where: str
    name: str = "nonsmooth"

    @property
    def key(self) -> str:
        """The table's name and axis."""
        return f"nonsmooth:{self.axis}"

    def columns(self, drivers=None) -> np.ndarray:
        """One indicator column per station (the residual no law explains), (n, n_stations)."""
        X = np.zeros((len(self.station), self.n))
        ok = self.station >= 0
        X[np.flatnonzero(ok), self.station[ok]] = 1.0
        return X

    def describe(self, coef, cov):
        """Where the table's largest values sit, in words."""
        k = int(np.argmax(np.abs(coef)))
        return (
            {"where": self.where, "peak_mm": float(coef[k])},
            {"peak_mm": float(np.sqrt(max(cov[k, k], 0)))},
            f"a local error of the {self.axis.upper()} reading {self.where} that no candidate effect has "
            f"(a damaged or dirty guide, a bump in a rail): modelled as a correction table there",
        )


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


# --- fitting and cross-validation ----------------------------------------------------------------
def _lstsq(X, r):
    """Least squares on scaled columns: QR with column pivoting (LAPACK's gelsy), which handles a
    rank-deficient X as the SVD does at a fraction of its cost on tall matrices."""
    if X.shape[1] == 0:
        return np.zeros(0)
    scale = np.linalg.norm(X, axis=0)
    scale[scale == 0] = 1.0
    return (
        linalg.lstsq(X / scale, r, cond=1e-12, lapack_driver="gelsy", check_finite=False)[0] / scale
    )


def _term_columns(term, drivers, sig: Signal, others: np.ndarray, train: np.ndarray, cache: dict):
    """Columns (m, k) of one term, its shape fixed on the training rows where it has one."""
    if isinstance(term, PeriodSearch):
        P, _ = best_period(sig.u[train], sig.r[train], others[train], term.periods)
        P, _ = refine_period(
            sig.u[train], sig.r[train], others[train], P, rel=_grid_rel(term.periods, P)
        )
        return Periodic(axis=term.axis, period_mm=P).columns({term.axis: sig.u})
    if hasattr(term, "fix"):  # a searched shape (a transmission's harmonic), on the training rows
        rows = np.ones(len(sig.r), bool) if train is None else train
        return term.fix(sig.r, others, rows, drivers).columns(drivers)
    if term.key not in cache:
        cache[term.key] = term.columns(drivers)
    return cache[term.key]


def cv_residuals(
    sig: Signal, terms: list, drivers: dict, fold: np.ndarray, cache: dict
) -> np.ndarray:
    """Held-out residuals (m,): each fold predicted from a fit to the others (``fold`` per sample)."""
    rows_fold = fold[sig.sample]
    out = np.empty_like(sig.r)
    for f in np.unique(rows_fold):
        test = rows_fold == f
        train = ~test
        X = sig.base
        for t in terms:
            X = np.c_[X, _term_columns(t, drivers, sig, X, train, cache)]
        coef = _lstsq(X[train], sig.r[train])
        out[test] = sig.r[test] - X[test] @ coef
    return out


def _rms(v) -> float:
    return float(np.sqrt(np.mean(np.square(v)))) if len(v) else 0.0


def fit_terms(sig: Signal, terms: list, drivers: dict, cache: dict, sigma: float | None):
    """All-data fit: fixed shapes (periods refined), coefficients, covariance, residual.

    The covariance takes the larger of the repeatability and the residual scatter (inflated
    for correlation by the caller through ``sigma``), so a poor model cannot look precise.
    """
    fixed, X = [], sig.base
    for t in terms:
        if isinstance(t, PeriodSearch):
            P0, _ = best_period(sig.u, sig.r, X, t.periods)
            P, P_std = refine_period(sig.u, sig.r, X, P0, rel=_grid_rel(t.periods, P0))
            t = Periodic(axis=t.axis, period_mm=P, period_std=P_std)
            cols = t.columns({t.axis: sig.u})
        elif hasattr(t, "fix"):
            t = t.fix(sig.r, X, np.ones(len(sig.r), bool), drivers)
            cols = t.columns(drivers)
        else:
            cols = _term_columns(t, drivers, sig, X, None, cache)
        fixed.append((t, X.shape[1], cols.shape[1]))
        X = np.c_[X, cols]
    coef = _lstsq(X, sig.r)
    res = sig.r - X @ coef
    s_res = float(np.sqrt(res @ res / max(len(res) - X.shape[1], 1)))
    s = max(s_res, sigma or 0.0)
    scale = np.linalg.norm(X, axis=0)
    scale[scale == 0] = 1.0
    Xs = X / scale
    cov = np.linalg.pinv(Xs.T @ Xs) / np.outer(scale, scale) * s * s
    return fixed, coef, cov, res


def _grid_rel(periods: np.ndarray, P0: float) -> float:
    """Half-width of the search around a grid period: 1.5 grid steps, relative."""
    k = int(np.argmin(np.abs(periods - P0)))
    step = np.abs(periods[min(k + 1, len(periods) - 1)] - periods[max(k - 1, 0)]) / 2
    return float(max(1.5 * step / P0, 1e-3))


def refine_period(u, r, base, P0, rel: float = 0.03) -> tuple[float, float]:
    """The period minimising the residual (variable projection: amplitudes solved inside),
    within ``rel`` of P0; its std from the curvature of the sum of squares."""

    def sse(P):
        X = np.c_[base, np.sin(2 * np.pi * u / P), np.cos(2 * np.pi * u / P)]
        e = r - X @ _lstsq(X, r)
        return float(e @ e)

    sol = optimize.minimize_scalar(
        sse, bounds=(P0 * (1 - rel), P0 * (1 + rel)), method="bounded", options={"xatol": P0 * 1e-7}
    )
    P, f0 = float(sol.x), float(sol.fun)
    h = P * 1e-4
    curv = (sse(P + h) - 2 * f0 + sse(P - h)) / (h * h)
    s2 = f0 / max(len(r) - base.shape[1] - 3, 1)
    return P, float(np.sqrt(2 * s2 / curv)) if curv > 0 else float("nan")


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
    """CUSUM: the index of the largest shift in mean and its statistic (max |S| / (sigma sqrt n))."""
    x = r_time_ordered - r_time_ordered.mean()
    S = np.cumsum(x)
    k = int(np.argmax(np.abs(S[:-1])))
    sd = np.std(np.diff(r_time_ordered)) / np.sqrt(2) + 1e-300
    return k, float(np.abs(S[k]) / (sd * np.sqrt(len(x))))


def where_text(v: np.ndarray, label: str) -> str:
    """The span of values ``v`` in words: "``label`` lo-hi mm" (or "= value" when they are all one)."""
    lo, hi = float(np.min(v)), float(np.max(v))
    return f"{label} {lo:.0f}-{hi:.0f} mm" if hi > lo else f"{label} = {lo:.0f} mm"


# --- selection -----------------------------------------------------------------------------------
@dataclasses.dataclass
class Step:
    term: object
    axis: str
    cv_before: float  # all signals, held out
    cv_after: float
    gain: float  # relative cut of its own axis's held-out RMS


@dataclasses.dataclass
class Discovery:
    steps: list[Step]
    rejected: dict[str, str]  # candidate key -> why it was not accepted
    cv_nominal: float
    cv_final: float
    rms_nominal: float
    cv_by_signal: dict


def _total_rms(cv_sq: dict, counts: dict) -> float:
    return float(np.sqrt(sum(cv_sq.values()) / sum(counts.values())))


def _coef_z(sig, terms, drivers, cache, sigma, term_index) -> float:
    fixed, coef, cov, _ = fit_terms(sig, terms, drivers, cache, sigma)
    _, start, k = fixed[term_index]
    c, C = coef[start : start + k], cov[start : start + k, start : start + k]
    try:
        return float(
            np.sqrt(c @ np.linalg.solve(C, c) / k) if k > 1 else abs(c[0]) / np.sqrt(C[0, 0])
        )
    except np.linalg.LinAlgError:
        return 0.0


def helps_everywhere(sig, terms, drivers, cache, fold, parts: int = 4, need: int = 3) -> bool:
    """A periodic error repeats: its last term must cut the held-out squared residual in at
    least ``need`` of ``parts`` stretches of the travel (a local bump helps in one)."""
    before = cv_residuals(sig, terms[:-1], drivers, fold, cache)
    after = cv_residuals(sig, terms, drivers, fold, cache)
    edges = np.quantile(sig.u, np.linspace(0, 1, parts + 1))
    idx = np.clip(np.searchsorted(edges, sig.u, side="right") - 1, 0, parts - 1)
    better = [
        np.sum(after[idx == k] ** 2) < 0.8 * np.sum(before[idx == k] ** 2) for k in range(parts)
    ]
    return sum(better) >= need


def select(
    signals: list[Signal],
    candidates: list,
    drivers: dict,
    fold: np.ndarray,
    noise: dict,
    floor: float = FLOOR,
    z_min: float = Z_MIN,
) -> tuple[Discovery, dict]:
    """Forward selection of candidate effects by held-out RMS (see the module's recipe).

    ``candidates``: Effects and PeriodSearches, each acting on the signal whose ``axis`` it
    names; ``noise``: axis -> Noise. Returns the discovery and the accepted terms per axis.
    """
    by_axis = {s.axis: s for s in signals}
    caches = {a: {} for a in by_axis}
    terms = {a: [] for a in by_axis}
    counts = {a: len(s.r) for a, s in by_axis.items()}
    cv_sq = {
        a: float(np.sum(cv_residuals(s, [], drivers, fold, caches[a]) ** 2))
        for a, s in by_axis.items()
    }
    cv_nominal = _total_rms(cv_sq, counts)
    rms_nominal = float(
        np.sqrt(
            sum(np.sum((s.r - s.base @ _lstsq(s.base, s.r)) ** 2) for s in signals)
            / sum(counts.values())
        )
    )
    remaining = [c for c in candidates if c.axis in by_axis]
    rejected, steps = {}, []
    while remaining:
        trials = []
        for c in remaining:
            a = c.axis
            sse = float(
                np.sum(cv_residuals(by_axis[a], terms[a] + [c], drivers, fold, caches[a]) ** 2)
            )
            gain = 1 - np.sqrt(sse / cv_sq[a])
            trials.append((gain, c, sse))
        trials.sort(key=lambda t: -t[0])
        accepted = None
        for gain, c, sse in trials:
            a = c.axis
            if gain < floor:
                rejected.setdefault(
                    c.key,
                    f"cuts the held-out RMS of {a} by {100 * max(gain, 0):.1f} % "
                    f"(< {100 * floor:.0f} %)",
                )
                continue
            sig_a = noise[a].sigma_mm * noise[a].inflation if noise[a].sigma_mm else None
            z = _coef_z(by_axis[a], terms[a] + [c], drivers, caches[a], sig_a, len(terms[a]))
            if z < z_min:
                rejected[c.key] = f"coefficients only {z:.1f} standard errors from zero"
                continue
            if isinstance(c, PeriodSearch) and not helps_everywhere(
                by_axis[a], terms[a] + [c], drivers, caches[a], fold
            ):
                rejected[c.key] = "helps in one stretch of the travel only: not periodic"
                continue
            accepted = (gain, c, sse)
            break
        if accepted is None:
            break
        gain, c, sse = accepted
        before = _total_rms(cv_sq, counts)
        cv_sq[c.axis] = sse
        terms[c.axis].append(c)
        steps.append(Step(c, c.axis, before, _total_rms(cv_sq, counts), float(gain)))
        remaining = [r for r in remaining if r is not c and r.key not in rejected]
        rejected.pop(c.key, None)
    cv_by = {a: float(np.sqrt(cv_sq[a] / counts[a])) for a in by_axis}
    return Discovery(
        steps, rejected, cv_nominal, _total_rms(cv_sq, counts), rms_nominal, cv_by
    ), terms


def refine(
    sig: Signal,
    terms: list,
    index: int,
    richer,
    drivers: dict,
    fold: np.ndarray,
    noise,
    floor: float = FLOOR,
    z_min: float = Z_MIN,
) -> tuple[bool, float, float]:
    """Whether the accepted ``terms[index]`` should become ``richer`` (the same effect with more
    columns, its own first, e.g. lost motion that grows along the travel): the held-out RMS of
    the signal must fall by ``floor`` and the added coefficients stand ``z_min`` standard errors
    from zero. Returns (accepted, held-out RMS before, after)."""
    trial = terms[:index] + [richer] + terms[index + 1 :]
    before = float(np.sqrt(np.mean(cv_residuals(sig, terms, drivers, fold, {}) ** 2)))
    after = float(np.sqrt(np.mean(cv_residuals(sig, trial, drivers, fold, {}) ** 2)))
    sigma = noise.sigma_mm * noise.inflation if noise.sigma_mm else None
    fixed, coef, cov, _ = fit_terms(sig, trial, drivers, {}, sigma)
    _, start, k = fixed[index]
    k0 = terms[index].columns(drivers).shape[1]
    c, C = coef[start + k0 : start + k], cov[start + k0 : start + k, start + k0 : start + k]
    try:
        z = float(np.sqrt(c @ np.linalg.solve(C, c) / len(c)))
    except np.linalg.LinAlgError:
        z = 0.0
    return bool(after <= (1 - floor) * before and z >= z_min), before, after


def prune(
    sig: Signal,
    found: Discovery,
    terms: dict,
    drivers: dict,
    fold: np.ndarray,
    floor: float = FLOOR,
) -> None:
    """Backward check after forward selection (one signal): an accepted effect that a later one
    made redundant (leaving it out now costs less than ``floor`` of the held-out RMS) goes, with
    the reason; the steps' held-out figures are then recomputed in order. In place."""
    a = sig.axis
    cache: dict = {}
    changed = True
    while changed and len(terms[a]) > 1:
        changed = False
        full = float(np.sum(cv_residuals(sig, terms[a], drivers, fold, cache) ** 2))
        for t in list(terms[a][1:]):  # the first is what everything else was found beside
            rest = [u for u in terms[a] if u is not t]
            without = float(np.sum(cv_residuals(sig, rest, drivers, fold, cache) ** 2))
            if 1 - np.sqrt(full / max(without, 1e-300)) < floor:
                later = ", ".join(u.key for u in terms[a][terms[a].index(t) + 1 :])
                found.rejected[t.key] = f"accepted first, then made redundant by {later}"
                terms[a] = rest
                changed = True
                break
    kept = {id(t) for t in terms[a]}
    steps = [st for st in found.steps if id(st.term) in kept]
    n = len(sig.r)
    prev = float(np.sqrt(np.sum(cv_residuals(sig, [], drivers, fold, cache) ** 2) / n))
    for i, st in enumerate(steps):
        now = float(
            np.sqrt(np.sum(cv_residuals(sig, terms[a][: i + 1], drivers, fold, cache) ** 2) / n)
        )
        st.cv_before, st.cv_after, st.gain = prev, now, 1 - now / prev
        prev = now
    found.steps[:] = steps
    found.cv_final = prev


def find_nonsmooth(
    sig: Signal,
    terms: list,
    drivers: dict,
    station: np.ndarray,
    positions: np.ndarray,
    noise: Noise,
    fold: np.ndarray,
    floor: float = FLOOR,
) -> StationTable | None:
    """Stations whose mean residual (over passes) stands out of the repeatability, grown to their
    neighbours; kept only if a correction table there helps held out. ``station`` (m,) ids per
    row, ``positions`` (n_stations, 2) their (x, y)."""
    if noise.sigma_mm is None:
        return None
    _, _, _, res = fit_terms(sig, terms, drivers, {}, None)
    ids, inv, counts = np.unique(station, return_inverse=True, return_counts=True)
    means = np.bincount(inv, weights=res) / counts
    z = means / (noise.sigma_mm * noise.inflation / np.sqrt(counts))
    hot = np.abs(z) > NONSMOOTH_Z
    if hot.sum() < 2:
        return None
    # grow to the neighbours that lean the same way (|z| > 2), within 3 station spacings
    pos = positions[ids]
    core = pos[hot]
    near = np.min(np.linalg.norm(pos[:, None] - core[None], axis=2), axis=1)
    spacing = np.median(np.sort(np.linalg.norm(pos[:, None] - pos[None], axis=2), axis=1)[:, 1])
    region = hot | ((np.abs(z) > 2) & (near <= 3 * spacing))
    table_id = -np.ones(len(ids), int)
    table_id[region] = np.arange(region.sum())
    reg = pos[region]
    peak = pos[np.argmax(np.abs(z))]
    where = (
        f"at {where_text(reg[:, 0], 'x')}, {where_text(reg[:, 1], 'y')} "
        f"(largest at x = {peak[0]:.0f} mm, y = {peak[1]:.0f} mm)"
    )
    table = StationTable(axis=sig.axis, station=table_id[inv], n=int(region.sum()), where=where)
    cache = {}
    before = _rms(cv_residuals(sig, terms, drivers, fold, cache))
    after = _rms(cv_residuals(sig, terms + [table], drivers, fold, cache))
    return table if after < (1 - floor) * before else None


def confounded(
    sig: Signal, terms: list, candidate, drivers: dict, cache: dict, limit: float = 0.9
) -> float:
    """The fraction of a candidate's column(s) that the scene model and the accepted terms
    already span (1 = indistinguishable). Above ``limit`` the data cannot tell them apart."""
    X = sig.base
    for t in terms:
        X = np.c_[X, _term_columns(t, drivers, sig, X, np.ones(len(sig.r), bool), cache)]
    C = _term_columns(candidate, drivers, sig, X, np.ones(len(sig.r), bool), cache)
    C = C - C.mean(0)
    if not np.any(C):
        return 1.0
    Q, _ = np.linalg.qr(X)
    left = C - Q @ (Q.T @ C)
    return float(1 - np.sum(left**2) / np.sum(C**2))
