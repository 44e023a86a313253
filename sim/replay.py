"""The twin replays a recording's commands: where the machine model says it went.

``discover`` compares a recording with this; the concealed-effect generator builds on it.
"""

from __future__ import annotations

import dataclasses

import numpy as np


def stage_travel_mm(scenario: str, geometry=None) -> tuple[float, float]:
    """The stage twin's travel in x and y (mm), from its home at 0. ``geometry``: the twin's
    (a ``--config`` file's; default: the scenario's own)."""
    if geometry is not None:
        return geometry.travel_mm
    if scenario == "belt-stage":
        from calibench.scenes.belt_stage import BeltStageGeometry

        return BeltStageGeometry().travel_mm
    if scenario == "vision-stage":
        from calibench.scenes.vision_stage import VisionStageGeometry

        return VisionStageGeometry().travel_mm
    raise ValueError(f"no stage twin for {scenario!r}")


def replay_stage(
    scenario: str,
    x: np.ndarray,
    y: np.ndarray,
    temp_c: np.ndarray | None = None,
    truth=None,
    geometry=None,
) -> np.ndarray:
    """Where the twin's carriage / table really is for each command in turn, (n, 2) mm from
    where it was homed. ``truth`` and ``geometry``: the twin's as-built parameters and its
    nominal geometry (default: the scenario's defaults, without random positioning);
    ``temp_c`` (n,): the room's temperature at each station, for a twin whose drives expand."""
    temps = [None] * len(x) if temp_c is None else np.asarray(temp_c, float)
    if scenario == "belt-stage":
        from calibench.scenes.belt_stage import BeltStageGeometry
        from calibench.sim.belt_stage import PULSES_PER_MM, BeltStageSim, BeltStageTruth

        sim = BeltStageSim(geometry or BeltStageGeometry(), truth or BeltStageTruth(), render=False)
        home = sim.carriage_mm()
        out = np.empty((len(x), 2))
        for i, (a, b, T) in enumerate(zip(x, y, temps)):
            sim.move(int(round(a * PULSES_PER_MM)), int(round(b * PULSES_PER_MM)), T)
            out[i] = sim.carriage_mm() - home
        return out
    if scenario == "vision-stage":
        from calibench.scenes.vision_stage import VisionStageGeometry
        from calibench.sim.vision_stage import VisionStageSim, VisionStageTruth

        truth = dataclasses.replace(truth or VisionStageTruth(), repeatability_um=0.0)
        g = geometry or VisionStageGeometry()
        table = VisionStageSim(g, truth, np.random.default_rng(0), render=False)
        home = table.true_point_mm(0.0, 0.0)
        out = np.empty((len(x), 2))
        for i, (a, b, T) in enumerate(zip(x, y, temps)):
            table.move(a, b, T)
            out[i] = table.point_in_body_mm("table") - home
        return out
    raise ValueError(f"no stage twin for {scenario!r}")


def replay_arm(q_rad: np.ndarray, arm: str = "arm-cmm") -> np.ndarray:
    """The nominal (rigid, drawing-value) arm's tool point in its base frame at encoder readings
    (n, N) rad, (n, 3) mm: MuJoCo's kinematics of the twin."""
    from calibench.scenes.arm_cmm import load_arm
    from calibench.sim.arm_cmm import ArmSim, ArmTruth

    description = load_arm(arm)
    return ArmSim(description, ArmTruth(delta=(0.0,) * (5 * description.n_joints + 3))).point_mm(
        q_rad
    )
