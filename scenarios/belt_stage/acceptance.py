"""ISO 230-2:2014 run on the belt stage's twin, each axis before and after its compensation.

Targets along each axis at mid-travel of the other: five a metre at least (clause 5.1), their
spacing made irregular so that a periodic error cannot hide between them; five bidirectional
runs, each target approached from below on the way out and from above on the way back (an
overshoot before the first target of each pass), the carriage's true position read by the
interferometer (its reading noise :data:`READING_UM`). Before compensation the stage is
commanded at the targets; after, at the maps' compensated commands. The figures are the
standard's (`estimators/stage/iso230_2.py`), in um, per axis.
"""

from __future__ import annotations

import math

import numpy as np

from calibench.estimators.stage import iso230_2
from calibench.estimators.stage.error_map import compensated_command
from calibench.scenarios.belt_stage.scenario import BeltStageConfig
from calibench.scenarios.belt_stage.uncertainty import measured_maps
from calibench.sim.belt_stage import PULSES_PER_MM

RUNS = 5  # bidirectional runs (clause 5.3.2)
READING_UM = 0.3  # the interferometer's reading noise, 1-sigma
OVERSHOOT_MM = 5.0  # the approach's run-in beyond each pass's first target
FIGURES = ("A", "B", "E", "M", "R")


def axis_targets(span_mm: float, rng: np.random.Generator) -> np.ndarray:
    """The targets (m,) mm over 5 % to 95 % of ``span_mm``: five a metre at least, each moved off
    an even spacing by up to a fifth of it."""
    m = max(5, math.ceil(5.0 * 0.9 * span_mm / 1000.0))
    even = np.linspace(0.05 * span_mm, 0.95 * span_mm, m)
    step = even[1] - even[0]
    return even + np.r_[0.0, rng.uniform(-0.2, 0.2, m - 2) * step, 0.0]


def runs(sim, commands_mm: np.ndarray, targets: np.ndarray, axis: int, rng) -> tuple:
    """Deviations up and down (m, RUNS) um of the carriage's true position on ``axis`` from each
    target, commanded at ``commands_mm`` (m, 2)."""
    up, down = np.empty((len(targets), RUNS)), np.empty((len(targets), RUNS))
    run_in = np.zeros(2)
    run_in[axis] = OVERSHOOT_MM
    for r in range(RUNS):
        for order, out, sign in (
            (range(len(targets)), up, -1),
            (reversed(range(len(targets))), down, 1),
        ):
            first = True
            for i in order:
                if first:  # the run-in: approach the pass's first target in the pass's direction
                    sim.move(*np.rint((commands_mm[i] + sign * run_in) * PULSES_PER_MM))
                    first = False
                went = sim.move(*np.rint(commands_mm[i] * PULSES_PER_MM))[axis]
                out[i, r] = 1000 * (went - targets[i]) + rng.normal(0, READING_UM)
    return up, down


def iso230_2_test(config: BeltStageConfig, seed: int) -> dict:
    """ISO 230-2's figures of both axes, before and after compensation (um)."""
    sim, maps = measured_maps(config, seed)
    rng = np.random.default_rng([seed, 230])
    out: dict = {"before": {}, "after": {}}
    try:
        travel = np.asarray(config.geometry.travel_mm, float)
        for axis, name in enumerate("xy"):
            targets = axis_targets(travel[axis], rng)
            at = np.tile(travel / 2, (len(targets), 1))
            at[:, axis] = targets
            comp = np.stack(
                compensated_command(at[:, 0], at[:, 1], maps.maps.fit_x, maps.maps.fit_y), 1
            )
            for which, commands in (("before", at), ("after", comp)):
                res = iso230_2.evaluate(targets, *runs(sim, commands, targets, axis, rng))
                out[which].update({f"{f}_{name}_um": float(getattr(res, f)) for f in FIGURES})
            out[f"targets_{name}_mm"] = targets.round(3).tolist()
    finally:
        sim.close()
    out["procedure"] = (
        f"ISO 230-2:2014 on each axis at mid-travel of the other: {len(targets)}-odd targets "
        f"irregularly spaced over 5-95 % of the travel, {RUNS} bidirectional runs with a "
        f"{OVERSHOOT_MM:g} mm run-in, the interferometer's reading noise {READING_UM:g} um; "
        "commanded at the targets before compensation and at the fitted maps' compensated "
        "commands after (the maps measured by the camera on the twin, analytic fidelity)"
    )
    return out
