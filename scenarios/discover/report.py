"""What every plug-in's discovery.json says the same way: the accepted effects described from the
final fit, the judgement (the noise floor, what is left unexplained and where, the verdict), the
fit and the noise.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np

from calibench.estimators.discovery.fit import (
    fit_terms,
    refined,
)
from calibench.estimators.discovery.noise import Floor, pooled
from calibench.estimators.discovery.select import Discovery

# the held-out RMS may exceed the noise floor by this factor before something is said to be left:
# the held-out prediction's own scatter (a few % for the parameters fitted) and the floor's
# sampling error (3 % from 500 pairs) stay well inside it; a slow effect at 1.5 times the noise
# does not
FLOOR_FACTOR = 1.2


def fit_and_noise(
    rms_nominal: float, found, noise: dict | None = None, after_noise: dict | None = None
) -> dict:
    """discovery.json's ``fit`` (the scene model's RMS, its held-out RMS and the final model's)
    and, where the instrument judges by repeats, ``noise`` and ``noise_after_effects`` (the
    repeatability before and after the accepted effects, by axis), written the same way for
    every instrument; ``found`` the selection."""
    out: dict = {
        "fit": {
            "rms_nominal": float(rms_nominal),
            "cv_rms_nominal": found.cv_nominal,
            "cv_rms_final": found.cv_final,
        }
    }
    if noise is not None and after_noise is not None:
        out["noise"] = {
            a: {"repeatability_mm": nz.sigma_mm, "lag1_correlation": nz.lag1, "dof": nz.dof}
            for a, nz in noise.items()
        }
        out["noise_after_effects"] = {
            a: {"repeatability_mm": nz.sigma_mm, "dof": nz.dof} for a, nz in after_noise.items()
        }
    return out


@dataclasses.dataclass
class Findings:
    """What an adapter found on one recording: the part of discovery.json every instrument
    writes the same way (docs/formats.md), before :func:`discovery_json` writes it.

    ``rms_nominal`` is the scene model's RMS over every reading (mm), ``found`` the selection
    (its held-out RMS and what it did not accept), ``judgement`` :func:`judged`'s keys, ``noise``
    and ``after_noise`` the repeatability by axis before and after the effects (None where the
    instrument does not judge by repeats), ``not_accepted`` the selection's rejected candidates
    unless the adapter has more to say (the arm's candidates that do not apply).
    """

    scenario: str
    samples: int
    rms_nominal: float
    found: Discovery
    effects: list[dict]
    located: list[dict]
    confounded: list[dict]
    judgement: dict
    holdout: str
    scene_model: str
    noise: dict | None = None
    after_noise: dict | None = None
    not_accepted: dict | None = None


def discovery_json(f: Findings, own: dict | None = None) -> dict:
    """discovery.json's content: the keys every instrument writes, in one order, with the
    instrument's ``own`` keys (its arm, its tracker's frame, its rail, its sessions) after the
    scene model."""
    return {
        "scenario": f.scenario,
        "samples": int(f.samples),
        "unit": "mm",
        "located": f.located,
        "effects": f.effects,
        **fit_and_noise(f.rms_nominal, f.found, f.noise, f.after_noise),
        "holdout": f.holdout,
        "scene_model": f.scene_model,
        **(own or {}),
        "not_accepted": f.found.rejected if f.not_accepted is None else f.not_accepted,
        "confounded": f.confounded,
        **f.judgement,
    }


def verdict(
    cv_final_mm: float, floor: Floor | None, found_any: bool, located: list | None = None
) -> str:
    """What is left after the accepted effects, in words: the final held-out RMS (per reading)
    against the recording's noise floor from its fastest repeats (:func:`noise_floor`). "Nothing
    missing" only within :data:`FLOOR_FACTOR` of the floor and with nothing ``located``;
    "unexplained" only beyond that factor of the floor's 95 % upper bound (few repeats, a loose
    floor); between the two, that it cannot be said. No floor to judge by is said, never taken
    for noise."""
    left = cv_final_mm * 1000
    if floor is None or floor.sigma_mm is None:
        return (
            f"what is left: {left:.2f} um held out; the recording has no repeats close in time "
            "and its successive readings are not repeats, so its noise floor is unknown and it "
            "cannot be said whether that is noise"
        )
    sigma = floor.sigma_mm * 1000
    said = f"{sigma:.2f} um noise floor from {floor.source}"
    upper = (floor.upper_mm or floor.sigma_mm) * 1000
    if FLOOR_FACTOR * sigma < left <= FLOOR_FACTOR * upper:
        return (
            f"near the noise floor: {left:.2f} um held out against a {said}, which its "
            f"{floor.pairs} pairs put anywhere up to {upper:.2f} um (95 %): whether something is "
            "left cannot be said; more repeats close in time would tell"
        )
    if left > FLOOR_FACTOR * sigma:
        return (
            f"unexplained: {left:.2f} um held out against a {said} ({left / sigma:.1f} x, above "
            f"{FLOOR_FACTOR:g} x); the residual's lag-1 correlation {floor.lag1_time:.2f} in time, "
            f"{floor.lag1_path:.2f} along the path: structure no candidate explains"
        )
    if not found_any and located:
        drivers = ", ".join(sorted({d["driver"] for d in located}))
        return (
            f"near the noise floor ({left:.2f} um held out, {said}), yet the residual follows "
            f"{drivers} (located): structure no candidate cuts by the acceptance floor, not noise"
        )
    what = (
        "the accepted effects explain" if found_any else "nothing missing: the scene model explains"
    )
    return (
        f"{what} the recording to its noise floor ({left:.2f} um held out, {said}, within "
        f"{FLOOR_FACTOR:g} x)"
    )


def judged(
    cv_final_mm: float,
    floors: dict[str, Floor],
    found_any: bool,
    located: list,
    where_left: Callable[[], list[dict]],
) -> dict:
    """discovery.json's judgement, the same for every instrument: ``noise_floor`` (pooled over
    the axes' ``floors``), ``unexplained`` (None, or what is left above :data:`FLOOR_FACTOR`
    times the floor: its RMS, the floor, and where it lives, the first of ``where_left()``: the
    instrument's location run on the final residual) and ``verdict``."""
    floor = pooled(floors)
    out: dict = {"noise_floor": None, "unexplained": None}
    if floor is not None and floor.sigma_mm is not None:
        out["noise_floor"] = {
            "sigma_mm": floor.sigma_mm,
            "from": floor.source,
            "pairs": floor.pairs,
            "upper_95_mm": floor.upper_mm,
            "factor": FLOOR_FACTOR,
            "lag1_time": floor.lag1_time,
            "lag1_path": floor.lag1_path,
        }
        if cv_final_mm > FLOOR_FACTOR * (floor.upper_mm or floor.sigma_mm):
            left = where_left()
            out["unexplained"] = {
                "rms": cv_final_mm,
                "noise_floor": floor.sigma_mm,
                "driver": left[0]["driver"] if left else None,
                "where": left[0]["where"]
                if left
                else "follows none of the drivers searched: fast structure, or noise unlike the "
                "floor's (heavy tails, a wander between passes)",
            }
    out["verdict"] = verdict(cv_final_mm, floor, found_any, located)
    if out["unexplained"] is not None:
        u = out["unexplained"]
        at = f"follows {u['driver']}: " if u["driver"] else ""
        out["verdict"] += f"; what is left {at}{u['where']}"
    return out


def describe_effects(signals, terms, found, drivers, noise):
    """Each accepted effect's parameters and standard errors from the final all-data fit."""
    by_axis = {s.axis: s for s in signals}
    fitted, described = {}, {}
    for a, sig in by_axis.items():
        nz = noise.get(a)
        sigma = nz.sigma_mm * nz.inflation if nz is not None and nz.sigma_mm else None
        fixed, coef, cov, res = fit_terms(sig, terms[a], drivers, {}, sigma, robust=True)
        again = refined(sig, fixed, drivers)
        if again is not None:
            fixed, coef, cov, res = fit_terms(sig, again, drivers, {}, sigma, robust=True)
        fitted[a] = res
        for term, (t, start, k) in zip(
            terms[a], fixed
        ):  # keyed by the term as selected (a search, fixed here)
            p, e, text = t.describe(
                coef[start : start + k], cov[start : start + k, start : start + k]
            )
            described[id(term)] = (t, p, e, text)
    effects = []
    for st in found.steps:
        t, p, e, text = described[id(st.term)]
        effects.append(
            {
                "name": t.name,
                "axis": st.axis,
                "params": plain(p),
                "stderr": plain(e),
                "physics": text,
                "cv_rms_before": st.cv_before,
                "cv_rms_after": st.cv_after,
            }
        )
    return effects, fitted


def plain(d: dict) -> dict:
    """A dict of numbers, arrays, strings and flags as JSON-ready Python values."""

    def one(v):
        if isinstance(v, (str, bool, np.bool_)) or v is None:
            return v if not isinstance(v, np.bool_) else bool(v)
        if isinstance(v, (list, tuple, np.ndarray)):
            return [one(x) for x in v]
        return int(v) if isinstance(v, (int, np.integer)) else float(v)

    return {k: one(v) for k, v in d.items()}


# what separates two look-alike mechanisms, by their names (either order)
SEPARATES = {
    frozenset({"backlash", "encoder_eccentricity"}): "approach the same angles from both "
    "directions: lost motion flips with the direction, an eccentricity does not",
    frozenset({"backlash", "periodic"}): "approach the same positions from both directions: lost "
    "motion flips with the direction, a periodic error does not",
    frozenset({"backlash", "reversal_transient"}): "measure finely over the first millimetres "
    "after a reversal: a transient dies away there, lost motion stays",
    frozenset({"encoder_eccentricity", "periodic"}): "measure over a whole turn of the joint at "
    "a finer step: the harmonic's order tells them apart",
    frozenset({"encoder_eccentricity", "joint_compliance"}): "take postures at the same angle "
    "under different gravity torques (the elbow folded and stretched)",
    frozenset({"thermal_expansion", "thermal_drift"}): "let the temperature move over the whole "
    "travel: an expansion grows with the position, a drift does not",
}


def separating(a: str, b: str) -> str:
    """The experiment that tells mechanism ``a`` from ``b``: a step at one moment against
    anything else, by repeating postures before and after it; otherwise from
    :data:`SEPARATES`, or repeating the rows where the two predict most differently."""
    if "step" in (a, b):
        return (
            "measure the same positions again at the start and the end: a step at one moment "
            "shows as the same offset on every repeat after it"
        )
    return SEPARATES.get(
        frozenset({a, b}),
        f"repeat the rows where {a} and {b} predict most differently, with more samples there",
    )


def named_only(effects: list[dict], found, duels: list) -> list[dict]:
    """Take out of ``effects`` (in ``found.steps``' order) each effect whose term did not beat
    its strongest look-alike (``duels``, :func:`~calibench.estimators.discovery.rivals.ties`):
    the model keeps it, the report names neither. Returns their ``confounded`` entries (the
    pair, the held-out RMS with each, the z and the experiment that separates them). In place
    on ``effects``."""
    tied = {id(d.term): d for d in duels}
    out, keep = [], []
    for e, st in zip(effects, found.steps):
        d = tied.get(id(st.term))
        if d is None:
            keep.append(e)
            continue
        rival = d.rival.name
        out.append(
            {
                "effect": e["name"],
                "axis": e["axis"],
                "with": d.rival.key,
                "params": e["params"],
                "why": f"held out, {e['name']} leaves {1000 * d.cv_term:.1f} um and {rival} in "
                f"its place {1000 * d.cv_rival:.1f} um: {e['name']} is only {d.z:.1f} standard "
                "errors better, so the recording cannot say which acts (the model keeps what they "
                "share)",
                "experiment": separating(e["name"], rival),
            }
        )
    effects[:] = keep
    return out
