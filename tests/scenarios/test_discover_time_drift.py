"""A stage whose reference drifts in time with no temperature logged: discover names a
``thermal_drift`` driven by ``t_s`` and says it in mm per hour (the contract's unit), at the size
planted. A null belt-stage recording of the twin (MuJoCo's replay, its noise) with the
temperature column dropped and 2 um per hour added to the X readings."""

import dataclasses

from calibench.scenarios.stages.discovery import discover_stage
from calibench.sim.concealed import stage_recording

DRIFT_MM_PER_H = 0.002


def test_a_drift_in_time_without_a_temperature_is_said_per_hour():
    """Within 3 of its standard error of the 2 um per hour planted (and within 10 %): a drift
    said per minute, or per second, is off by 60 or 3600."""
    rec, _ = stage_recording("belt-stage", "null", 3)
    drifted = dataclasses.replace(
        rec, x_meas_mm=rec.x_meas_mm + DRIFT_MM_PER_H * rec.t_s / 3600, temp_c=None
    )
    out, _ = discover_stage("belt-stage", drifted, 0)
    (e,) = [e for e in out["effects"] if e["name"] == "thermal_drift"]
    assert e["axis"] == "x" and set(e["params"]) == {"mm_per_h"}, e
    got, std = e["params"]["mm_per_h"], e["stderr"]["mm_per_h"]
    assert abs(got - DRIFT_MM_PER_H) < max(3 * std, 0.1 * DRIFT_MM_PER_H), (got, std)
    assert abs(got / DRIFT_MM_PER_H - 1) < 0.1, got
