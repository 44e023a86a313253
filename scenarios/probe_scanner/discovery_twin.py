"""The probe scanner's twin updated by ``discover --twin``: the accepted effects written as the
scanner simulation's parameters, on top of the twin that was replayed."""

from __future__ import annotations

import numpy as np

from calibench.scenarios.probe_scanner import NAME


def twin_table(out: dict, given: dict | None = None) -> dict:
    """``discover --twin``: the accepted effects as parameters of the scanner's simulation (the
    ``[probe-scanner.truth]`` table of a ``run --config`` file), with the calibrated rail, on
    top of ``given`` (the replayed config's own truth table, as written): what discover found
    is what that twin left, so a run-out of a harmonic it had, or its eccentricity, adds as a
    phasor and a scale adds its ppm (to first order, as the effects are small)."""
    truth = {**(given or {}), **out["twin_rail"]}
    runout: dict[int, complex] = {}
    for k, a, ph in zip(
        truth.get("runout_harmonics", ()),
        truth.get("runout_mm", ()),
        truth.get("runout_phase_rad", ()),
    ):  # a harmonic the twin lists twice is the sum of both (the simulation adds them)
        runout[int(k)] = runout.get(int(k), 0) + a * np.exp(1j * ph)
    had = set(runout)
    raw = {}  # a harmonic the twin did not have: as found
    for p in (e["params"] for e in out["effects"] if e["name"] == "runout"):
        k = int(p["harmonic"])
        if k in had:
            runout[k] += p["amplitude_mm"] * np.exp(1j * p["phase_rad"])
        else:
            raw[k] = (p["amplitude_mm"], p["phase_rad"])
    if runout or raw:
        phases = {k: (float(abs(z)), float(np.angle(z))) for k, z in runout.items()} | raw
        truth["runout_harmonics"] = list(phases)
        truth["runout_mm"] = [a for a, _ in phases.values()]
        truth["runout_phase_rad"] = [ph for _, ph in phases.values()]
    for e in out["effects"]:
        p = e["params"]
        if e["name"] == "encoder_eccentricity":
            z = truth.get("encoder_eccentricity_urad", 0.0) * np.exp(
                1j * truth.get("encoder_eccentricity_phase_rad", 0.0)
            ) + p["amplitude_urad"] * np.exp(1j * p["phase_rad"])
            first = "encoder_eccentricity_urad" not in truth
            truth["encoder_eccentricity_urad"] = p["amplitude_urad"] if first else float(abs(z))
            truth["encoder_eccentricity_phase_rad"] = (
                p["phase_rad"] if first else float(np.angle(z))
            )
        elif e["name"] == "scale":
            truth["probe_scale_ppm"] = truth.get("probe_scale_ppm", 0.0) + p["ppm"]
    return {NAME: {"truth": truth}}
