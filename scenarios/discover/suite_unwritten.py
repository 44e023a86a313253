"""The second concealed-effect suite: effects no candidate writes down, under noise that is not
as assumed (issue 36).

Each recording carries one effect of ``sim.concealed.unwritten`` (or none: a null) and reading
noise of one misspecified kind (``t3``, ``drift``, ``outliers``, by the case's seed), and goes
through ``discover`` blind. Scoring, against the sealed manifest afterwards:

- detection: the truth's ``nearest`` named effect found on its axis; a ``nonsmooth`` also
  located where the effect lives (a stage: its largest deviation within a tenth of the travel of
  the joint; the scanner: on the thin arc, 2 deg of slack). A truth that states its size
  (``rms_um``) and is too small for any candidate to pass the selection's floor is counted
  apart (:func:`within_reach`): removed whole, it would not cut the held-out RMS by the floor;
- false claims: an effect found that is neither a truth's nearest (on its axis, leg or joint,
  where it lives) nor named ``alike`` by it (on a null: any effect; an arm's calibrated
  ``geometry`` is the scene model's, not a claim);
- improvement on the selection's folds: its held-out RMS after the accepted effects below that
  of the scene model (after its calibrated geometry, where it has one). In-sample for the
  structure: the selection accepts only what lowers it on those folds;
- improvement on a fresh recording: the same machine recorded again (the same plan, its noise
  fresh: ``repeat=1``), the structure the first recording chose fitted there fold by fold and
  scored on its held-out rows, beside the scene model alone (:mod:`.fresh`): rows that chose
  nothing.
"""

from __future__ import annotations

import dataclasses
from collections import defaultdict

import numpy as np

from calibench.estimators.discovery.select import FLOOR
from calibench.scenarios.discover.engine import plugin
from calibench.scenarios.discover.fresh import FreshScore, score_on_fresh
from calibench.scenarios.discover.suite import recorded, searched
from calibench.scenarios.registry import instruments
from calibench.sim.concealed.heat import SIMULATED_STAGE_KINDS, SIMULATED_STEWART_KINDS
from calibench.sim.concealed.noise import MISSPECIFIED, THIRD_SUITE_NOISES, noise_rms
from calibench.sim.concealed.simulated import SIMULATED_ARM_KINDS

SEEDS = 3  # per kind: each kind sees every misspecified noise once


def unwritten_cases() -> tuple[tuple[str, str, int], ...]:
    """The suite's cases (scenario, kind, seed): each instrument's ``unwritten`` kinds, as the
    registry lists them, :data:`SEEDS` recordings of each and its ``unwritten_nulls`` nulls."""
    return tuple(
        (row.name, kind, s)
        for row in instruments()
        for kind in row.unwritten
        for s in range(row.unwritten_nulls if kind == "null" else SEEDS)
    )


SEED0 = 9000  # the recordings' seeds: apart from the first suite's and the coverage study's
NOT_CONCEALED = ("geometry",)
BLIND_FACTOR = 1.5  # "nothing missing" above this many times the true noise is blind
SIMULATED_KINDS = SIMULATED_ARM_KINDS + SIMULATED_STAGE_KINDS + SIMULATED_STEWART_KINDS


def case_noise(seed: int, kind: str = "") -> str:
    """The case's reading noise: the misspecified kinds in turn (the third suite's, ``kind`` a
    simulated mechanism, quantised readings among them)."""
    kinds = THIRD_SUITE_NOISES if kind in SIMULATED_KINDS else MISSPECIFIED
    return kinds[seed % len(kinds)]


@dataclasses.dataclass
class UnwrittenResult:
    scenario: str
    kind: str
    seed: int
    noise: str
    truth: list
    found: list
    detected: int
    false_claims: int
    cv_before: float
    cv_after: float
    fresh: FreshScore
    verdict: str = ""
    noise_mm: float = 0.0  # the RMS of the reading noise the recording was made with
    below_floor: int = 0  # truths out of the selection's reach (:func:`within_reach`)
    detected_below: int = 0  # of those, found all the same

    @property
    def blind_verdict(self) -> bool:
        """Whether the verdict says "nothing missing" while the held-out residual is above
        :data:`BLIND_FACTOR` times the true noise (the acceptance's figure)."""
        return (
            self.verdict.startswith("nothing missing")
            and self.cv_after > BLIND_FACTOR * self.noise_mm
        )


def _matches(scenario: str, t: dict, f: dict) -> bool:
    if f["name"] != t["nearest"] or f["axis"] != t["axis"]:
        return False
    for where in ("leg", "joint"):  # a truth may name several (a bent link: either joint)
        want = t["params"].get(where)
        if want is not None and f["params"].get(where) not in np.atleast_1d(want):
            return False
    # a nonsmooth table is a match where it sits where the effect lives: the adapter's words
    return f["name"] != "nonsmooth" or plugin(scenario).nonsmooth_at(scenario, t, f)


def _explained(scenario: str, truth: list, f: dict) -> bool:
    """Whether a found effect is a truth's nearest, where it lives, or named ``alike`` by it."""
    return any(
        _matches(scenario, t, f) or (f["name"] in t.get("alike", ()) and f["axis"] == t["axis"])
        for t in truth
    )


def within_reach(truth: dict, cv_before_mm: float) -> bool:
    """Whether a truth, removed whole, would cut the held-out RMS ``cv_before_mm`` (which holds
    it) by the selection's floor: ``1 - sqrt(cv^2 - e^2) / cv >= FLOOR``, ``e`` its stated RMS
    (``rms_um``; a truth that states none is taken to be within reach). The best any candidate
    can do, so a truth beyond it is missed by the rule, not by the search."""
    if "rms_um" not in truth:
        return True
    left = np.sqrt(max(cv_before_mm**2 - (truth["rms_um"] / 1000) ** 2, 0.0))
    return bool(1 - left / cv_before_mm >= FLOOR)


def run_unwritten(scenario: str, kind: str, seed: int, noise: str | None = None) -> UnwrittenResult:
    """One case through discover, scored against its manifest (``noise``: None, the case's)."""
    noise, rec_seed = noise or case_noise(seed, kind), SEED0 + 100 * seed + len(kind)

    def discovered(repeat: int) -> tuple[dict, dict, dict]:
        rec, manifest = recorded(scenario, kind, rec_seed, noise=noise, repeat=repeat)
        return (*searched(scenario, rec, seed), manifest)

    out, chosen, manifest = discovered(0)
    fresh = score_on_fresh(chosen, discovered(1)[1])
    truth = manifest["effects"]
    found = [e for e in out["effects"] if e["name"] not in NOT_CONCEALED]
    hit = [any(_matches(scenario, t, f) for f in found) for t in truth]
    false = sum(not _explained(scenario, truth, f) for f in found)
    geo = [e for e in out["effects"] if e["name"] in NOT_CONCEALED]
    before = geo[-1]["cv_rms_after"] if geo else out["fit"]["cv_rms_nominal"]
    beyond = [not within_reach(t, before) for t in truth]
    return UnwrittenResult(
        scenario,
        kind,
        seed,
        noise,
        truth,
        found,
        sum(hit),
        false,
        before,
        out["fit"]["cv_rms_final"],
        fresh,
        out.get("verdict", ""),
        noise_rms(noise, manifest["noise_um"] / 1000),
        sum(beyond),
        sum(h and b for h, b in zip(hit, beyond)),
    )


def score_unwritten(results: list[UnwrittenResult]) -> dict:
    """Per instrument: recordings, detection (of the truths within the selection's reach), the
    truths beyond it, the share of null recordings with a false claim,
    false claims beside real effects, the share of effect recordings improved on the
    selection's folds (in-sample for the structure) and on a fresh recording (held out: its
    rows chose nothing) with the median of its RMS after over before, and the null recordings
    a fresh recording finds worse with what the first chose."""
    by = defaultdict(list)
    for r in results:
        by[r.scenario].append(r)
    out = {}
    for scenario, rs in by.items():
        nulls = [r for r in rs if r.kind == "null"]
        real = [r for r in rs if r.kind != "null"]
        reach = sum(len(r.truth) - r.below_floor for r in real)
        out[scenario] = {
            "recordings": len(rs),
            "detection": sum(r.detected - r.detected_below for r in real) / max(reach, 1),
            "below_floor": sum(r.below_floor for r in real),
            "null_false_claim_rate": sum(r.false_claims > 0 for r in nulls) / max(len(nulls), 1),
            "spurious_claims": sum(r.false_claims for r in real),
            "improved": sum(r.cv_after < r.cv_before for r in real) / max(len(real), 1),
            "improved_fresh": sum(
                r.fresh.cv_rms_with_effects < r.fresh.cv_rms_scene_model for r in real
            )
            / max(len(real), 1),
            "fresh_ratio": float(
                np.median(
                    [r.fresh.cv_rms_with_effects / r.fresh.cv_rms_scene_model for r in real]
                    or [np.nan]
                )
            ),
            "nulls_worse_fresh": sum(
                r.fresh.cv_rms_with_effects > r.fresh.cv_rms_scene_model for r in nulls
            ),
        }
    return out


def unwritten_table(results: list[UnwrittenResult]) -> str:
    """The suite's cases as a Markdown table."""
    lines = [
        "| scenario | kind | noise | concealed (nearest named) | found | selection's folds (um) "
        "| fresh recording (um) |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in results:
        truth = ", ".join(f"{t['name']} -> {t['nearest']}({t['axis']})" for t in r.truth) or "-"
        found = ", ".join(f"{f['name']}({f['axis']})" for f in r.found) or "-"
        lines.append(
            f"| {r.scenario} | {r.kind} | {r.noise} | {truth} | {found} | "
            f"{1000 * r.cv_before:.2f} -> {1000 * r.cv_after:.2f} | "
            f"{1000 * r.fresh.cv_rms_scene_model:.2f} -> {1000 * r.fresh.cv_rms_with_effects:.2f} |"
        )
    return "\n".join(lines)
