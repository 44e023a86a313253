"""The third concealed-effect suite (issue 61): mechanisms simulated, not written, under heavy
tails, drift, gross readings and counts.

Each recording carries one mechanism of ``sim.concealed.simulated`` (MuJoCo's: an arm's gear
with play, an encoder disc slipped at a hard stop) or ``sim.concealed.heat`` (heat networks
integrated in time: a stage's scales warmed through the base, a Stewart leg warmed by its
motor), or none, and the reading noise of :data:`~calibench.sim.concealed.noise.THIRD_SUITE_NOISES`
in turn by seed; it goes through ``discover`` blind and is scored as the second suite's are
(:func:`~calibench.scenarios.discover.suite_unwritten.run_unwritten`).
"""

from __future__ import annotations

from calibench.scenarios.discover.suite_unwritten import (
    UnwrittenResult,
    run_unwritten,
    score_unwritten,
)
from calibench.scenarios.registry import instruments
from calibench.sim.concealed.noise import THIRD_SUITE_NOISES

SEEDS = len(THIRD_SUITE_NOISES)  # per kind and instrument: each noise once


def simulated_kinds() -> tuple[tuple[str, tuple[str, ...]], ...]:
    """Each instrument's suite label (``NAME:ARM`` where it runs with an arm of its own) and its
    third-suite kinds, as the registry lists them."""
    return tuple(
        (f"{row.name}:{row.simulated_arm}" if row.simulated_arm else row.name, row.simulated)
        for row in instruments()
        if row.simulated
    )


def simulated_cases() -> tuple[tuple[str, str, int, str], ...]:
    """The suite's cases (label, kind, seed, noise): each instrument's simulated kinds and a
    null, :data:`SEEDS` recordings of each, the noises in turn."""
    return tuple(
        (label, kind, s, THIRD_SUITE_NOISES[s % len(THIRD_SUITE_NOISES)])
        for label, kinds in simulated_kinds()
        for kind in (*kinds, "null")
        for s in range(SEEDS)
    )


def run_simulated(label: str, kind: str, seed: int, noise: str) -> UnwrittenResult:
    """One case through discover, scored against its manifest."""
    return run_unwritten(label, kind, seed, noise=noise)


def simulated_scores(results: list[UnwrittenResult]) -> dict:
    """Per instrument, the second suite's scores, the recordings with any false claim and those
    whose verdict says "nothing missing" above 1.5 times the true noise."""
    scores = score_unwritten(results)
    for label, s in scores.items():
        mine = [r for r in results if r.scenario == label]
        s["false_recordings"] = sum(r.false_claims > 0 for r in mine)
        s["blind_verdicts"] = sum(r.blind_verdict for r in mine)
    return scores
