"""The scenarios by name: each declares its config, its run, and its model for ``fit``."""

from __future__ import annotations

import dataclasses
from typing import Callable

from calibench.scenarios import arm_cmm, belt_stage, probe_scanner, stewart, vision_stage


@dataclasses.dataclass(frozen=True)
class Scenario:
    name: str
    config: type
    run: Callable  # (config, seed, fidelity, out_dir, rrd) -> Report
    fit_model: str | None = None  # the calibration model ``calibench fit`` applies


SCENARIOS = {
    belt_stage.NAME: Scenario(belt_stage.NAME, belt_stage.BeltStageConfig, belt_stage.run, "quadratic"),
    vision_stage.NAME: Scenario(vision_stage.NAME, vision_stage.VisionStageConfig, vision_stage.run, "cubic"),
    probe_scanner.NAME: Scenario(probe_scanner.NAME, probe_scanner.ProbeScannerConfig, probe_scanner.run),
    arm_cmm.NAME: Scenario(arm_cmm.NAME, arm_cmm.ArmCmmConfig, arm_cmm.run),
    stewart.NAME: Scenario(stewart.NAME, stewart.StewartConfig, stewart.run),
}

# Named in the contract, built by later issues.
PLANNED: tuple[str, ...] = ()
