"""``discover --twin`` / ``--config``: what discovery found, as the scenario's simulation parameters.

The twin file is a ``run --config`` file: ``discover --config`` replays the recording with it in
MuJoCo (the residual then is simulated, not fitted), and ``run`` / ``montecarlo`` simulate the
machine with what was found. Each instrument's effects map onto fields of its ``*Truth``:

- stages: ``drive_x`` / ``drive_y`` (``sim.stage_drive.DriveErrors``): lost motion (constant or
  growing along the travel), the periodic error, thermal expansion about the recording's mean
  temperature;
- the probe scanner: see ``discover_scanner.twin_table``;
- the arm: the chain's errors (``ArmTruth.delta``) and each joint's stiffness from the
  compliance found under gravity (``stiffness_nm_per_rad``, inf: rigid);
- the Stewart platform: the calibrated hinges and initial lengths (``[stewart.geometry]``) and
  each leg's compliance, thermal growth, lost motion and screw pitch (``StewartTruth.leg_*``).

Effects the simulation has no parameter for (a drift with time, a nonsmooth table) are listed in
the file's header as not carried.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

from calibench.scenarios.report import BadInput

STAGE_CONFIGS = {
    "belt-stage": ("calibench.scenarios.belt_stage.scenario", "BeltStageConfig"),
    "vision-stage": ("calibench.scenarios.vision_stage.scenario", "VisionStageConfig"),
}


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
                d = dataclasses.replace(
                    d,
                    reversal_at_home_um=d.reversal_at_home_um + home * 1000,
                    reversal_growth_um_per_m=d.reversal_growth_um_per_m
                    + p.get("growth_mm_per_m", 0.0) * 1000,
                )
            elif e["name"] == "periodic":
                d = dataclasses.replace(
                    d,
                    periodic_um=p["amplitude_mm"] * 1000,
                    period_mm=p["period_mm"],
                    periodic_phase_rad=p["phase_rad"],
                )
            elif e["name"] == "thermal_expansion" and out.get("temp_mean_c") is not None:
                d = dataclasses.replace(
                    d,
                    thermal_ppm_per_k=d.thermal_ppm_per_k + p["ppm_per_k"],
                    reference_temp_c=out["temp_mean_c"],
                )
            else:
                left.append(f"{e['name']} ({a})")
        drives[f"drive_{a}"] = dataclasses.asdict(d)
    return drives, left


def _stewart(out: dict, config: Path | None) -> tuple[dict, list[str]]:
    """The platform's twin: the hinges and lengths with the found geometry, the legs' physics."""
    import numpy as np

    from calibench.scenarios.config import load_toml, override
    from calibench.scenarios.stewart.scenario import StewartConfig

    cfg = StewartConfig()
    if config is not None:
        cfg = override(cfg, load_toml(config).get("stewart", {}), "stewart")
    g, t = cfg.geometry, cfg.truth
    r, B, l0 = (
        np.array(a, float) for a in (g.platform_hinges_mm, g.base_hinges_mm, g.initial_lengths_mm)
    )
    leg = {
        k: list(getattr(t, k))
        for k in (
            "leg_compliance_um_per_n",
            "leg_thermal_ppm_per_k",
            "leg_reversal_um",
            "leg_pitch_um",
            "leg_pitch_lead_mm",
            "leg_pitch_phase_rad",
        )
    }
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
    geometry = {
        "platform_hinges_mm": r.tolist(),
        "base_hinges_mm": B.tolist(),
        "initial_lengths_mm": l0.tolist(),
    }
    return {"stewart": {"geometry": geometry, "truth": truth}}, left


def arm_truth(description, path: Path | None):
    """The arm twin's truth from a ``--config`` file's ``[arm-cmm.truth]`` (None: the nominal,
    rigid arm)."""
    if path is None:
        return None
    from calibench.scenarios.config import load_toml, override
    from calibench.sim.arm_cmm import ArmTruth

    t = override(
        ArmTruth(delta=(0.0,) * (5 * description.n_joints + 3)),
        load_toml(path).get("arm-cmm", {}).get("truth", {}),
        "arm-cmm.truth",
    )
    return t


def _arm(out: dict, config: Path | None, arm) -> tuple[dict, list[str]]:
    """The arm's twin: the chain's errors (``delta``, the identifiable ones found, the dropped
    ones zero) and each joint's stiffness from its compliance under gravity."""
    import math

    from calibench.estimators.arm.kinematics import param_names
    from calibench.scenes.arm_cmm import load_arm

    description = load_arm(arm or "arm-cmm")
    N = description.n_joints
    base = arm_truth(description, config)
    delta = list(base.delta) if base is not None and base.delta else [0.0] * (5 * N + 3)
    stiffness = (
        list(base.stiffness_nm_per_rad)
        if base is not None and base.stiffness_nm_per_rad
        else [math.inf] * N
    )
    names, left = param_names(N), []
    for e in out["effects"]:
        p = e["params"]
        if e["name"] == "geometry":
            for k, v in p.items():
                if k in names:
                    delta[names.index(k)] += v
        elif e["name"] == "joint_compliance" and p["urad_per_nm"] > 0:
            j = p["joint"] - 1
            c = p["urad_per_nm"] * 1e-6 + (1 / stiffness[j] if math.isfinite(stiffness[j]) else 0.0)
            stiffness[j] = 1 / c
        else:
            left.append(e["name"] + (f" (joint {p['joint']})" if "joint" in p else ""))
    return {"arm-cmm": {"truth": {"delta": delta, "stiffness_nm_per_rad": stiffness}}}, left


def twin_tables(scenario: str, out: dict, config: Path | None, arm=None) -> tuple[dict, list[str]]:
    """The twin file's tables for ``scenario`` from discovery.json's content ``out``, and the
    accepted effects the simulation cannot carry."""
    if scenario in STAGE_CONFIGS:
        truth = _config(scenario, config).truth
        drives, left = _stage_drives(out, truth)
        return {scenario: {"truth": drives}}, left
    if scenario == "probe-scanner":
        from calibench.scenarios.discover.probe_scanner import twin_table

        left = [
            e["name"]
            for e in out["effects"]
            if e["name"] not in ("runout", "encoder_eccentricity", "scale")
        ]
        return twin_table(out), left
    if scenario == "stewart":
        return _stewart(out, config)
    if scenario == "arm-cmm":
        return _arm(out, config, arm)
    raise BadInput(f"discover --twin: no twin parameters for {scenario}")
