"""``discover --twin`` on top of a replayed twin: what discover finds against a ``--config``
twin is what that twin left, so the written twin is the config's own, whole, with the findings
added to it (not put in place of it). Only the findings discovery confirmed are written; those
it did not are listed in the file's header, discovery.json and the console, never carried."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path


def split_confirmed(effects: list[dict]) -> tuple[list[dict], list[str]]:
    """The effects a twin may carry, and the names of those it must not.

    Parameters
    ----------
    effects : list of dict
        discovery.json's ``effects``, each with its ``status`` (``confirm``).

    Returns
    -------
    kept : list of dict
        The effects confirmed under every held-out scheme tried (or never put to one).
    unconfirmed : list of str
        The others, as ``name (axis)``: one scheme held them out and they did not carry.
    """
    kept = [e for e in effects if e.get("status") != "not confirmed"]
    unconfirmed = [
        f"{e['name']} ({e['axis']})" for e in effects if e.get("status") == "not confirmed"
    ]
    return kept, unconfirmed


def twin_note(recording, left: list[str], unconfirmed: list[str]) -> str:
    """The twin file's header: whose twin it is, and what it does not carry and why (a line
    each)."""
    lines = [f"the twin of {recording} updated by calibench discover"]
    if left:
        lines[0] += "; not carried by the simulation: " + ", ".join(left)
    if unconfirmed:
        lines.append(
            "NOT CONFIRMED, so not written here: " + ", ".join(unconfirmed) + " (discovery.json "
            "says under which held-out scheme each did not carry)"
        )
    return "\n".join(lines)


def twin_said(found: dict, twin: Path, scenario: str) -> str:
    """The console's line(s) on the twin written: where, how to replay it, and the effects left
    out of it as not confirmed."""
    said = (
        f"-> {twin} (the twin with what was found: calibench discover {scenario} ... --config "
        f"{twin} replays it)"
    )
    unconfirmed = found.get("twin", {}).get("not_confirmed", [])
    if unconfirmed:
        said += f"\n   not written into it, NOT CONFIRMED: {', '.join(unconfirmed)}"
    return said


def given_tables(config: Path | None, scenario: str) -> dict:
    """The config file's table of ``scenario`` as written (empty without a file)."""
    if config is None:
        return {}
    from calibench.scenarios.config import load_toml

    return load_toml(config).get(scenario, {})


def carried(given: dict, written: dict) -> dict:
    """``given``'s tables with ``written``'s entries over them, one level of sub-tables deep
    (``[x.truth]`` keeps the entries the update does not write)."""
    out = dict(given)
    for k, v in written.items():
        old = given.get(k)
        out[k] = {**old, **v} if isinstance(v, dict) and isinstance(old, dict) else v
    return out


def thermal_on_top(k1: float, ref1: float, k2: float, ref2: float) -> tuple[float, float] | None:
    """Two expansions of one scale, ``k1 (T - ref1) + k2 (T - ref2)`` (ppm/K, deg C), as one:
    ``(k1 + k2) (T - ref)``, exactly; None when they cancel and leave ``(k1 ref1 + k2 ref2)``
    of constant scale error, which no expansion writes."""
    if k1 == 0:
        return k2, ref2
    k = k1 + k2
    if k == 0:
        return None
    return k, (k1 * ref1 + k2 * ref2) / k


def periodic_on_top(
    a1: float, period1: float, phase1: float, a2: float, period2: float, phase2: float
) -> tuple[float, float, float] | None:
    """Two periodic errors ``a sin(2 pi u / period + phase)`` of one drive as one: a sum of
    phasors when their periods agree (to 1e-9), the second alone where the twin had none;
    None when the periods differ (one drive carries one period)."""
    if a1 == 0:
        return a2, period2, phase2
    if not math.isclose(period1, period2, rel_tol=1e-9):
        return None
    z = complex(a1 * math.cos(phase1), a1 * math.sin(phase1)) + complex(
        a2 * math.cos(phase2), a2 * math.sin(phase2)
    )
    return abs(z), period1, math.atan2(z.imag, z.real)


def stage_drives(out: dict, truth) -> tuple[dict, list[str]]:
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
            elif e["name"] == "periodic" and (
                both := periodic_on_top(
                    d.periodic_um,
                    d.period_mm,
                    d.periodic_phase_rad,
                    p["amplitude_mm"] * 1000,
                    p["period_mm"],
                    p["phase_rad"],
                )
            ):
                d = dataclasses.replace(
                    d, periodic_um=both[0], period_mm=both[1], periodic_phase_rad=both[2]
                )
            elif (
                e["name"] == "thermal_expansion"
                and out.get("temp_mean_c") is not None
                and (
                    thermal := thermal_on_top(
                        d.thermal_ppm_per_k, d.reference_temp_c, p["ppm_per_k"], out["temp_mean_c"]
                    )
                )
            ):
                d = dataclasses.replace(
                    d, thermal_ppm_per_k=thermal[0], reference_temp_c=thermal[1]
                )
            else:
                left.append(f"{e['name']} ({a})")
        drives[f"drive_{a}"] = dataclasses.asdict(d)
    return drives, left
