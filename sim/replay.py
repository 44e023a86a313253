"""The twin replays a recording's commands: where the machine model says it went.

``discover`` compares a recording with this; the concealed-effect generator builds on it.
"""

from __future__ import annotations

import dataclasses

import numpy as np


def replay_stage(
    geometry,
    x: np.ndarray,
    y: np.ndarray,
    temp_c: np.ndarray | None = None,
    truth=None,
) -> np.ndarray:
    """Where the twin's carriage / table really is for each command in turn, (n, 2) mm from
    where it was homed. ``geometry``: the stage twin's nominal geometry, which says which stage
    it is (a ``BeltStageGeometry`` or a ``VisionStageGeometry``); ``truth``: its as-built
    parameters (default: none, without random positioning); ``temp_c`` (n,): the room's
    temperature at each station, for a twin whose drives expand."""
    from calibench.scenes.belt_stage import BeltStageGeometry
    from calibench.scenes.vision_stage import VisionStageGeometry

    temps = [None] * len(x) if temp_c is None else np.asarray(temp_c, float)
    if isinstance(geometry, BeltStageGeometry):
        from calibench.sim.belt_stage import PULSES_PER_MM, BeltStageSim, BeltStageTruth

        sim = BeltStageSim(geometry, truth or BeltStageTruth(), render=False)
        home = sim.carriage_mm()
        out = np.empty((len(x), 2))
        for i, (a, b, T) in enumerate(zip(x, y, temps)):
            sim.move(int(round(a * PULSES_PER_MM)), int(round(b * PULSES_PER_MM)), T)
            out[i] = sim.carriage_mm() - home
        return out
    if isinstance(geometry, VisionStageGeometry):
        from calibench.sim.vision_stage import VisionStageSim, VisionStageTruth

        truth = dataclasses.replace(truth or VisionStageTruth(), repeatability_um=0.0)
        table = VisionStageSim(geometry, truth, np.random.default_rng(0), render=False)
        home = table.true_point_mm(0.0, 0.0)
        out = np.empty((len(x), 2))
        for i, (a, b, T) in enumerate(zip(x, y, temps)):
            table.move(a, b, T)
            out[i] = table.point_in_body_mm("table") - home
        return out
    raise ValueError(f"no stage twin for a {type(geometry).__name__}")
