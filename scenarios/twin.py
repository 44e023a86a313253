"""``discover --twin`` / ``--config``: what discovery found, as the scenario's simulation parameters.

The twin file is a ``run --config`` file: ``discover --config`` replays the recording with it in
MuJoCo (the residual then is simulated, not fitted), and ``run`` / ``montecarlo`` simulate the
machine with what was found. Each instrument's effects map onto fields of its ``*Truth``:

- stages: ``drive_x`` / ``drive_y`` (``sim.stage_drive.DriveErrors``): lost motion (constant or
  growing along the travel), the periodic error, thermal expansion about the recording's mean
  temperature;
- the probe scanner: see ``discover_scanner.twin_table``.

Effects the simulation has no parameter for (a drift with time, a nonsmooth table) are listed in
the file's header as not carried.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

from calibench.scenarios.report import BadInput

STAGE_CONFIGS = {"belt-stage": ("calibench.scenarios.belt_stage", "BeltStageConfig"),
                 "vision-stage": ("calibench.scenarios.vision_stage", "VisionStageConfig")}


def _config(scenario: str, path: Path | None):
    """The scenario's run config, overridden by the file at ``path`` (None: the defaults)."""
    import importlib

    from calibench.scenarios.config import load_toml, override

    module, name = STAGE_CONFIGS[scenario]
    cfg = getattr(importlib.import_module(module), name)()
    if path is not None:
        cfg = override(cfg, load_toml(path).get(scenario, {}), scenario)
    return cfg


def stage_truth(scenario: str, path: Path | None):
    """The stage twin's as-built truth for ``discover``: the config file's, or None (the defaults)."""
    return None if path is None else _config(scenario, path).truth


def _stage_drives(out: dict, truth) -> tuple[dict, list[str]]:
    """Each axis's ``DriveErrors`` with the accepted effects written in (on top of ``truth``'s)."""
    drives, left = {}, []
    for a in ("x", "y"):
        d = getattr(truth, f"drive_{a}")
        for e in (e for e in out["effects"] if e["axis"] == a):
            p = e["params"]
            if e["name"] == "backlash":
                home = p.get("reversal_at_home_mm", p["reversal_mm"])
                d = dataclasses.replace(d, reversal_at_home_um=d.reversal_at_home_um + home * 1000,
                                        reversal_growth_um_per_m=d.reversal_growth_um_per_m
                                        + p.get("growth_mm_per_m", 0.0) * 1000)
            elif e["name"] == "periodic":
                d = dataclasses.replace(d, periodic_um=p["amplitude_mm"] * 1000, period_mm=p["period_mm"],
                                        periodic_phase_rad=p["phase_rad"])
            elif e["name"] == "thermal_expansion" and out.get("temp_mean_c") is not None:
                d = dataclasses.replace(d, thermal_ppm_per_k=d.thermal_ppm_per_k + p["ppm_per_k"],
                                        reference_temp_c=out["temp_mean_c"])
            else:
                left.append(f"{e['name']} ({a})")
        drives[f"drive_{a}"] = dataclasses.asdict(d)
    return drives, left


def twin_tables(scenario: str, out: dict, config: Path | None) -> tuple[dict, list[str]]:
    """The twin file's tables for ``scenario`` from discovery.json's content ``out``, and the
    accepted effects the simulation cannot carry."""
    if scenario in STAGE_CONFIGS:
        truth = _config(scenario, config).truth
        drives, left = _stage_drives(out, truth)
        return {scenario: {"truth": drives}}, left
    if scenario == "probe-scanner":
        from calibench.scenarios.discover_scanner import twin_table

        left = [e["name"] for e in out["effects"] if e["name"] not in ("runout", "encoder_eccentricity", "scale")]
        return twin_table(out), left
    raise BadInput(f"discover --twin: no twin parameters for {scenario}")
