"""Forward selection of candidate effects by held-out error, and the checks after it (refine,
prune): the engine's decisions. The recipe: :mod:`calibench.estimators.discovery`.
"""

from __future__ import annotations

import dataclasses
import os
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numpy as np

from calibench.estimators.discovery.effect import Drivers
from calibench.estimators.discovery.fit import (
    Signal,
    cv_residuals,
    fit_terms,
    keep_fixed,
    lstsq,
    rms,
    session_residuals,
    term_columns,
)

MAX_WORKERS = 4  # threads scoring candidates: numpy's kernels release the GIL
FLOOR = 0.10  # practical floor: an effect must cut its axis's held-out RMS by 10 %
Z_MIN = 5.0  # and be at least 5 standard errors from zero


# --- selection -----------------------------------------------------------------------------------
@dataclasses.dataclass
class Step:
    """One accepted term: the selection's held-out RMS over every signal before and after it."""

    term: Any  # an accepted candidate: an Effect, a found period's term, or a correction table
    axis: str
    cv_before: float  # all signals, held out
    cv_after: float
    gain: float  # relative cut of its own axis's held-out RMS


@dataclasses.dataclass
class Discovery:
    """What the selection accepted, in order, what it did not and why, and the held-out RMS of
    the scene model and of the final model (mm)."""

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
        z2 = c @ np.linalg.solve(C, c) / k if k > 1 else c[0] ** 2 / C[0, 0]
    except np.linalg.LinAlgError:
        return 0.0
    # a singular covariance (columns the others span) gives no evidence, not a NaN
    return float(np.sqrt(z2)) if np.isfinite(z2) and z2 > 0 else 0.0


def _implausible(sig, terms, drivers, cache, sigma, term_index) -> str:
    """The candidate's words where its fit on every row lies outside its physical range."""
    fixed, coef, cov, _ = fit_terms(sig, terms, drivers, cache, sigma)
    term, start, k = fixed[term_index]
    check = getattr(term, "implausible", None)
    return (
        check(coef[start : start + k], cov[start : start + k, start : start + k]) if check else ""
    )


def small_gain(axis: str, gain: float, floor: float, z: float, z_min: float) -> str:
    """Why a candidate below the floor is not accepted, its gain to two figures (a real effect
    that matters little here is not scored zero) and, when its coefficients stand out of the
    noise anyway, that it is real but too small to matter at this residual."""
    cut = (
        f"cuts the held-out RMS of {axis} by {100 * gain:.2g} %"
        if gain > 0
        else f"does not cut the held-out RMS of {axis} ({100 * -gain:.2g} % higher)"
    )
    text = f"{cut} (< {100 * floor:.0f} %)"
    if z >= z_min and gain > 0:
        text += (
            f", though {z:.1f} standard errors from zero beside the effects before it: real, too "
            "small to matter against what this recording leaves"
        )
    elif z >= z_min:
        text += (
            f", though {z:.1f} standard errors from zero fitted on every row: what it fits there "
            "does not carry to postures held out"
        )
    return text


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


# a local effect's rows: where its column reaches this share of its largest
ACTING_SHARE = 0.1


def gain_where_it_acts(sig, terms: list, c, drivers: Drivers, cache: dict, fold) -> float | None:
    """The cut of the held-out RMS a ``local`` candidate ``c`` (an effect confined to some rows:
    a transient after each reversal) makes on the rows it acts on (its column, fixed on every
    row beside ``terms``, at least :data:`ACTING_SHARE` of its largest), beside ``terms``; None
    when its shape, fixed there, runs to the bound of its search (then it is not confined)."""
    X = sig.base
    for t in terms:
        X = np.c_[X, term_columns(t, drivers, sig, X, None, cache)]
    fixed = c.fix(sig.r, X, np.ones(len(sig.r), bool), drivers) if hasattr(c, "fix") else c
    if getattr(fixed, "at_bound", False):
        return None
    col = np.abs(np.asarray(fixed.columns(drivers), float)).max(axis=1)
    acting = col >= ACTING_SHARE * col.max() if col.max() > 0 else np.zeros(len(col), bool)
    if not acting.any():
        return 0.0
    before = cv_residuals(sig, terms, drivers, fold, cache)[acting]
    after = cv_residuals(sig, terms + [c], drivers, fold, cache)[acting]
    return float(1 - np.sqrt(np.sum(after**2) / max(np.sum(before**2), 1e-300)))


def select(
    signals: list[Signal],
    candidates: list,
    drivers: Drivers,
    fold: np.ndarray,
    noise: dict,
    floor: float = FLOOR,
    z_min: float = Z_MIN,
    workers: int | None = None,
) -> tuple[Discovery, dict]:
    """Forward selection of candidate effects by held-out RMS (see the module's recipe).

    ``candidates``: Effects and PeriodSearches, each acting on the signal whose ``axis`` it
    names; ``noise``: axis -> Noise; ``workers``: threads scoring a round's candidates (default
    the cores, at most ``MAX_WORKERS``; the result is the same for any number). Returns the
    discovery and the accepted terms per axis.
    """
    by_axis = {s.axis: s for s in signals}
    caches: dict[str, dict[str, np.ndarray]] = {a: {} for a in by_axis}  # term key -> columns
    terms: dict[str, list] = {a: [] for a in by_axis}
    counts = {a: len(s.r) for a, s in by_axis.items()}
    cv_sq = {
        a: float(np.sum(cv_residuals(s, [], drivers, fold, caches[a]) ** 2))
        for a, s in by_axis.items()
    }
    cv_nominal = _total_rms(cv_sq, counts)
    rms_nominal = float(
        np.sqrt(
            sum(np.sum((s.r - s.base @ lstsq(s.base, s.r)) ** 2) for s in signals)
            / sum(counts.values())
        )
    )
    remaining = [c for c in candidates if c.axis in by_axis]
    rejected: dict[str, str] = {}
    steps: list[Step] = []

    def held_out_sse(c) -> float:
        a = c.axis
        return float(
            np.sum(cv_residuals(by_axis[a], terms[a] + [c], drivers, fold, caches[a]) ** 2)
        )

    # The candidates of a round are independent (their shared caches hold the same values
    # whichever computes them first): scored side by side, numpy's work releasing the GIL.
    pool = ThreadPoolExecutor(max_workers=workers or min(os.cpu_count() or 1, MAX_WORKERS))
    while remaining:
        sses = list(pool.map(held_out_sse, remaining))
        trials = [(1 - np.sqrt(sse / cv_sq[c.axis]), c, sse) for c, sse in zip(remaining, sses)]
        trials.sort(key=lambda t: -t[0])
        accepted = None
        for gain, c, sse in trials:
            a = c.axis
            sig_a = noise[a].sigma_mm * noise[a].inflation if noise[a].sigma_mm else None
            if getattr(c, "local", False):
                # an effect confined to some rows is judged on them, the rest not risen
                gain_there = gain_where_it_acts(by_axis[a], terms[a], c, drivers, caches[a], fold)
                if gain_there is None:
                    rejected[c.key] = (
                        "its shape runs to the longest tried: not confined to a few rows"
                    )
                    continue
                if floor > gain > 0 and gain_there >= floor:
                    gain = gain_there
            if gain < floor:
                if c.key not in rejected:
                    z = _coef_z(
                        by_axis[a], terms[a] + [c], drivers, caches[a], sig_a, len(terms[a])
                    )
                    rejected[c.key] = small_gain(a, gain, floor, z, z_min)
                continue
            z = _coef_z(by_axis[a], terms[a] + [c], drivers, caches[a], sig_a, len(terms[a]))
            if z < z_min:
                rejected[c.key] = f"coefficients only {z:.1f} standard errors from zero"
                continue
            odd = _implausible(by_axis[a], terms[a] + [c], drivers, caches[a], sig_a, len(terms[a]))
            if odd:
                rejected[c.key] = odd
                continue
            if getattr(c, "periodic", False) and not helps_everywhere(
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
        keep_fixed(caches[c.axis], terms[c.axis])
        steps.append(Step(c, c.axis, before, _total_rms(cv_sq, counts), float(gain)))
        remaining = [r for r in remaining if r is not c and r.key not in rejected]
        rejected.pop(c.key, None)
    pool.shutdown()
    cv_by = {a: float(np.sqrt(cv_sq[a] / counts[a])) for a in by_axis}
    return Discovery(
        steps, rejected, cv_nominal, _total_rms(cv_sq, counts), rms_nominal, cv_by
    ), terms


def keep_table(
    signals: list[Signal],
    terms: dict[str, list],
    found: Discovery,
    drivers: Drivers,
    fold: np.ndarray,
    tables: list,
    floor: float = 0.0,
) -> object | None:
    """The pipeline's step for what no candidate explains, the same for every instrument: of
    ``tables`` (corrections over a driver, each on its ``axis``: a stage's stations, a scanner's
    angles, an arm's joint angle; proposed by the instrument), the one that lowers the held-out
    RMS over every signal most, kept if it does so by more than ``floor`` (a fraction): appended
    to its axis's ``terms`` and to ``found``'s steps, ``found.cv_final`` updated.

    Returns
    -------
    The table kept, or None.
    """
    by_axis = {s.axis: s for s in signals}
    caches: dict[str, dict] = {s.axis: {} for s in signals}
    n = sum(len(s.r) for s in signals)

    def sse(s: Signal, with_terms: list) -> float:
        return float(np.sum(cv_residuals(s, with_terms, drivers, fold, caches[s.axis]) ** 2))

    cv_sq = {s.axis: sse(s, terms[s.axis]) for s in signals}
    before = float(np.sqrt(sum(cv_sq.values()) / n))
    best = None
    for t in tables:
        trial = {**cv_sq, t.axis: sse(by_axis[t.axis], terms[t.axis] + [t])}
        after = float(np.sqrt(sum(trial.values()) / n))
        if after < (1 - floor) * before and (best is None or after < best[1]):
            best = (t, after)
    if best is None:
        return None
    table, after = best
    terms[table.axis].append(table)
    found.steps.append(Step(table, table.axis, before, after, 1 - after / before))
    found.cv_final = after
    return table


def refine(
    sig: Signal,
    terms: list,
    index: int,
    richer,
    drivers: Drivers,
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
    drivers: Drivers,
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
    restep(sig, found, terms[a], drivers, fold, cache)


def restep(sig: Signal, found: Discovery, kept: list, drivers, fold, cache: dict) -> None:
    """Keep the steps of the terms ``kept`` (in their order) and recompute their held-out
    figures in order, and the final one. In place."""
    ids = {id(t) for t in kept}
    steps = [st for st in found.steps if id(st.term) in ids]
    n = len(sig.r)
    prev = float(np.sqrt(np.sum(cv_residuals(sig, [], drivers, fold, cache) ** 2) / n))
    for i, st in enumerate(steps):
        now = float(
            np.sqrt(np.sum(cv_residuals(sig, kept[: i + 1], drivers, fold, cache) ** 2) / n)
        )
        st.cv_before, st.cv_after, st.gain = prev, now, 1 - now / prev
        prev = now
    found.steps[:] = steps
    found.cv_final = prev


def carry_to_new_sessions(
    sig: Signal,
    found: Discovery,
    terms: list,
    drivers: Drivers,
    fold: np.ndarray,
    session: np.ndarray,
    register: np.ndarray,
) -> dict[int, dict]:
    """Which accepted effects belong to the machine: held out whole sessions
    (:func:`~calibench.estimators.discovery.fit.session_residuals`: the others' fit carried to
    the session, what is its own fitted on its ``register`` rows), an effect that carries lowers
    the RMS of every session; one that does not belongs to the sessions it was found in and goes
    (with the reason, worst first, until every one left carries; the first term stays:
    everything else was found beside it). The steps are then recomputed. In place.

    Returns
    -------
    {id(term): {"without": .., "with": ..}}: the new sessions' RMS without and with each term
    kept (the first's not).
    """
    cache: dict = {}
    rows_session = session[sig.sample]
    sessions = np.unique(rows_session)

    def new_session_rms(ts) -> np.ndarray:
        """(sessions + 1,): each session's RMS held out whole, then all of them together."""
        e = session_residuals(sig, ts, drivers, session, register, cache)
        ok = np.isfinite(e)
        return np.array([rms(e[ok & (rows_session == k)]) for k in sessions] + [rms(e[ok])])

    while True:
        full = new_session_rms(terms)
        without = {id(t): new_session_rms([u for u in terms if u is not t]) for t in terms[1:]}
        # an effect of the machine helps every session it is carried to, not only on average
        ratio = {
            i: float(np.max(full[:-1] / np.maximum(w[:-1], 1e-300))) for i, w in without.items()
        }
        worst = max(terms[1:], key=lambda t: ratio[id(t)], default=None)
        if worst is None or ratio[id(worst)] < 1.0:
            break
        w = without[id(worst)]
        k = int(np.argmax(full[:-1] / np.maximum(w[:-1], 1e-300)))
        found.rejected[worst.key] = (
            f"found within the sessions, but held out whole session {int(sessions[k]) + 1} is no "
            f"better with it ({w[k] * 1000:.0f} um without, {full[k] * 1000:.0f} um with): it "
            "belongs to the sessions it was found in, not to the machine"
        )
        del terms[next(i for i, u in enumerate(terms) if u is worst)]  # by identity
    restep(sig, found, terms, drivers, fold, {})
    return {
        id(t): {
            "without": float(without[id(t)][-1]),
            "with": float(full[-1]),
            "by_session_without": without[id(t)][:-1].tolist(),
            "by_session_with": full[:-1].tolist(),
        }
        for t in terms[1:]
    }
