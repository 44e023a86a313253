"""``discover --twin`` / ``--config``: what discovery found, as the scenario's simulation parameters.

The twin file is a ``run --config`` file: ``discover --config`` replays the recording with it in
MuJoCo (the residual then is simulated, not fitted), and ``run`` / ``montecarlo`` simulate the
machine with what was found. Each instrument's effects map onto fields of its ``*Truth``:

- stages: ``drive_x`` / ``drive_y`` (``sim.stage_drive.DriveErrors``): lost motion (constant or
  growing along the travel), the periodic error, thermal expansion about the recording's mean
  temperature;
- the probe scanner: see ``discover_scanner.twin_table``;
- the Stewart platform: the calibrated hinges and initial lengths (``[stewart.geometry]``) and
  each leg's compliance, thermal growth, lost motion and screw pitch (``StewartTruth.leg_*``).

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


def _stewart(out: dict, config: Path | None) -> tuple[dict, list[str]]:
    """The platform's twin: the hinges and lengths with the found geometry, the legs' physics."""
    import numpy as np

    from calibench.scenarios.config import load_toml, override
    from calibench.scenarios.stewart import StewartConfig

    cfg = StewartConfig()
    if config is not None:
        cfg = override(cfg, load_toml(config).get("stewart", {}), "stewart")
    g, t = cfg.geometry, cfg.truth
    r, B, l0 = (np.array(a, float) for a in (g.platform_hinges_mm, g.base_hinges_mm, g.initial_lengths_mm))
    leg = {k: list(getattr(t, k)) for k in ("leg_compliance_um_per_n", "leg_thermal_ppm_per_k", "leg_reversal_um",
                                            "leg_pitch_um", "leg_pitch_lead_mm", "leg_pitch_phase_rad")}
    ref, left = t.reference_temp_c, []
    for e in out["effects"]:
        p = e["params"]
        i = p.get("leg", 0) - 1
        if e["name"] == "geometry":
            for k in range(6):
                r[k] += [p[f"r{c}{k + 1}"] for c in "xyz"]
                B[k] += [p[f"B{c}{k + 1}"] for c in "xyz"]
                l0[k] += p[f"l{k + 1}"]
        elif e["name"] == "leg_compliance":
            for k in range(6) if i < 0 else (i,):
                leg["leg_compliance_um_per_n"][k] += p["um_per_n"]
        elif e["name"] == "thermal_expansion" and out.get("temp_mean_c") is not None:
            leg["leg_thermal_ppm_per_k"][i] += p["ppm_per_k"]
            ref = out["temp_mean_c"]
        elif e["name"] == "backlash":
            leg["leg_reversal_um"][i] += p["reversal_mm"] * 1000
        elif e["name"] == "periodic":
            leg["leg_pitch_um"][i] = p["amplitude_mm"] * 1000
            leg["leg_pitch_lead_mm"][i] = p["period_mm"]
            leg["leg_pitch_phase_rad"][i] = p["phase_rad"]
        else:
            left.append(e["name"])
    truth = {**leg, "reference_temp_c": ref}
    geometry = {"platform_hinges_mm": r.tolist(), "base_hinges_mm": B.tolist(), "initial_lengths_mm": l0.tolist()}
    return {"stewart": {"geometry": geometry, "truth": truth}}, left


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
    if scenario == "stewart":
        return _stewart(out, config)
    raise BadInput(f"discover --twin: no twin parameters for {scenario}")
