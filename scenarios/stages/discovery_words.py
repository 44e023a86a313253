"""What the stages' discovery says in words: where a residual lives (each against each driver,
whole-pass permutation tests), and the candidates the data cannot tell from what the model
already has, each with the experiment that would."""

from __future__ import annotations

import numpy as np

from calibench.estimators.discovery.confounds import find_confounds
from calibench.estimators.discovery.effect import Drivers
from calibench.estimators.discovery.fit import Signal, lstsq
from calibench.estimators.discovery.locate import (
    Driver,
    change_point,
    follows,
    reversal_profile,
)
from calibench.estimators.discovery.select import Discovery
from calibench.estimators.discovery.stage import PeriodSearch

# the located structure: a residual against a driver is listed where its permutation p-value is at
# most this (and its binned R^2 at least LOCATE_MIN_SCORE)
LOCATE_P = 0.01
LOCATE_MIN_SCORE = 0.02


EXPERIMENTS = {
    "thermal_expansion": "let the machine's temperature change by several K during the test (or "
    "repeat it warm and cold and give both to discover: `calibench discover SCENARIO cold.csv "
    "warm.csv`): only then does thermal expansion differ from a plain scale error",
    "thermal_drift": "hold the temperature steady for part of the test, or vary it independently "
    "of time",
    "backlash": "approach every station from both directions",
    "periodic": "measure at a finer step over a longer travel",
    "positioning": "measure more stations along the axis",
    "straightness": "measure more lines across the travel",
    "cross_coupling": "measure a full grid rather than lines",
}


def locate_stage(signals: list[Signal], drivers: Drivers, seed: int) -> list[dict]:
    """Each residual (after the scene model) against each driver, whole-pass permutation tests."""
    rng = np.random.default_rng(seed)
    passes = drivers["run"] if drivers.get("run") is not None else np.zeros(len(signals[0].r))
    names = ("x", "y", "dir_x", "dir_y", "t_s", "temp_c")
    tested = [
        Driver(name, drivers.get(name), "passes" if name in ("t_s", "temp_c") else "shift")
        for name in names
    ]
    out = []
    for s in signals:
        r = s.r - s.base @ lstsq(s.base, s.r)
        for f in follows(r, tested, passes, rng, LOCATE_P, LOCATE_MIN_SCORE):
            out.append(
                {
                    "signal": s.name,
                    "driver": f.name,
                    "score": f.score,
                    "p_value": f.p,
                    "where": where_said(r, f.values, f.name, drivers),
                }
            )
    return sorted(out, key=lambda d: -d["score"])


def where_said(r: np.ndarray, v: np.ndarray, name: str, drivers: Drivers) -> str:
    """Where the residual ``r`` (n,) follows the driver ``name`` (values ``v`` (n,)), in words:
    a reversal's profile along its axis, a change point in time, or the band of the travel with
    the largest mean."""
    if name.startswith("dir_"):
        axis = name[-1]
        c, prof = reversal_profile(r, np.asarray(drivers[axis], float), v)
        ok = np.isfinite(prof)
        return (
            f"whole {axis.upper()} travel: forward minus backward {np.nanmean(prof) * 1000:+.1f} "
            f"um (from {np.nanmin(prof[ok]) * 1000:+.1f} to {np.nanmax(prof[ok]) * 1000:+.1f} um "
            "along it)"
        )
    if name in ("t_s", "temp_c"):
        k, stat = change_point(
            r[np.argsort(drivers["t_s"])] if drivers.get("t_s") is not None else r
        )
        unit = "s" if name == "t_s" else "deg C"
        return f"follows {name} ({unit}); largest shift after sample {k} (CUSUM {stat:.1f})"
    edges = np.quantile(v, np.linspace(0, 1, 9))
    idx = np.clip(np.searchsorted(edges, v, side="right") - 1, 0, 7)
    means = np.array([np.mean(r[idx == k]) if np.any(idx == k) else 0 for k in range(8)])
    k = int(np.argmax(np.abs(means)))
    return (
        f"largest at {name} {edges[k]:.0f}-{edges[k + 1]:.0f} mm (mean {means[k] * 1000:+.1f} um)"
    )


def stage_confounds(
    signals: list[Signal], terms: dict, found: Discovery, candidates: list, drivers: Drivers, rec
) -> list[dict]:
    """Physical candidates the data cannot tell from what the model already has, each with the
    experiment that would (smooth polynomial terms are left out: they are meant to overlap)."""
    out = []
    accepted = {st.term.key for st in found.steps} | {
        f"{st.term.name}:{st.axis}" for st in found.steps
    }
    asked = [
        c
        for c in candidates
        if c.key not in accepted
        and f"{c.name}:{c.axis}" not in accepted  # a lagged variant of an accepted effect
        and not isinstance(c, PeriodSearch)
        and c.name not in ("positioning", "straightness", "cross_coupling")
    ]
    for f in find_confounds({s.axis: s for s in signals}, terms, asked, drivers, rec.temp_c):
        c = f.candidate
        if f.cause == "temperature":
            out.append(
                {
                    "effect": c.name,
                    "axis": f.axis,
                    "with": "scale",
                    "why": f"the temperature moved only {f.temperature_span_k:.2f} K, so an "
                    f"expansion coefficient would look like (and be absorbed by) a scale error",
                    "experiment": EXPERIMENTS[c.name],
                }
            )
        else:
            out.append(
                {
                    "effect": c.name,
                    "axis": f.axis,
                    "with": "the scene model and the accepted effects",
                    "why": f"{100 * f.fraction:.0f} % of its effect on the data is also what the "
                    "model already has",
                    "experiment": EXPERIMENTS.get(c.name, "vary its driver independently"),
                }
            )
    return out
