"""The Stewart platform's twin with what discover found written in: ``discover stewart --twin``'s
tables (the plug-in protocol's ``twin_tables``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from calibench.scenarios.stewart import NAME


def twin_tables(scenario: str, out: dict, config: Path | None, arm=None) -> tuple[dict, list[str]]:
    """The platform's twin: the hinges and lengths with the found geometry, the legs' physics."""

    from calibench.scenarios.config import load_toml, override
    from calibench.scenarios.discover.twin_merge import (
        carried,
        given_tables,
        periodic_on_top,
        thermal_on_top,
    )
    from calibench.scenarios.stewart.scenario import StewartConfig

    cfg = StewartConfig()
    if config is not None:
        cfg = override(cfg, load_toml(config).get(NAME, {}), NAME)
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
            ppm = leg["leg_thermal_ppm_per_k"]
            both = thermal_on_top(ppm[i], ref, p["ppm_per_k"], out["temp_mean_c"])
            # the legs share one reference temperature: another leg's expansion fixes it
            if both is None or (any(ppm[j] for j in range(6) if j != i) and both[1] != ref):
                left.append(f"{e['name']} (leg {i + 1})")
            else:
                ppm[i], ref = both
        elif e["name"] == "backlash":
            leg["leg_reversal_um"][i] += p["reversal_mm"] * 1000
        elif e["name"] == "periodic" and (
            pitch := periodic_on_top(
                leg["leg_pitch_um"][i],
                leg["leg_pitch_lead_mm"][i],
                leg["leg_pitch_phase_rad"][i],
                p["amplitude_mm"] * 1000,
                p["period_mm"],
                p["phase_rad"],
            )
        ):
            leg["leg_pitch_um"][i], leg["leg_pitch_lead_mm"][i], leg["leg_pitch_phase_rad"][i] = (
                pitch
            )
        else:
            left.append(e["name"] + (f" (leg {i + 1})" if i >= 0 else ""))
    truth = {**leg, "reference_temp_c": ref}
    geometry = {
        "platform_hinges_mm": r.tolist(),
        "base_hinges_mm": B.tolist(),
        "initial_lengths_mm": l0.tolist(),
    }
    written = {"geometry": geometry, "truth": truth}
    return {NAME: carried(given_tables(config, NAME), written)}, left
