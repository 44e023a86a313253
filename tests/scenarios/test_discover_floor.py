"""The verdict's noise floor (issue 61): from a recording's fastest repeats, so a slow effect no
candidate writes down cannot raise it and hide behind it; and the lag a scale's temperature
follows the air with, searched. The stages' unwritten ``lagged_thermal`` recordings (the scale's
own temperature follows the logged air through a first-order lag) and a null, against the
generator's stated noise (1 um, Gaussian)."""

import pytest

from calibench.estimators.discovery.lag import LagSearch
from calibench.scenarios.discover.report import FLOOR_FACTOR
from calibench.scenarios.stages.discovery import discover_stage
from calibench.sim.concealed import stage_recording

# the floor's own sampling error from ~3000 successive pairs is about 1.3 %: 5 % is 4 sigma
FLOOR_TOL = 0.05


@pytest.mark.parametrize("scenario", ["belt-stage", "vision-stage"])
def test_a_lagged_thermal_scale_is_left_unexplained_not_hidden_in_the_floor(scenario, monkeypatch):
    """Without the lag among the candidates (as before issue 61): the floor is the readings'
    noise, not noise plus the slow change between passes (the repeatability from repeats hours
    apart was 3-4 x it); the held-out residual above 1.2 x the floor is said ``unexplained``,
    with its RMS and the floor."""
    monkeypatch.setattr(LagSearch, "applies", lambda self, drivers: False)
    rec, manifest = stage_recording(scenario, "lagged_thermal", 0)
    noise = manifest["noise_um"] / 1000
    out, _ = discover_stage(scenario, rec, 0)
    floor = out["noise_floor"]
    assert abs(floor["sigma_mm"] / noise - 1) < FLOOR_TOL, floor
    assert floor["factor"] == FLOOR_FACTOR == 1.2
    left = out["unexplained"]
    assert left is not None and out["verdict"].startswith("unexplained:"), out["verdict"]
    assert left["rms"] == out["fit"]["cv_rms_final"] > 1.5 * noise
    assert left["noise_floor"] == floor["sigma_mm"]


def test_a_null_stage_is_judged_at_its_noise_and_nothing_is_missing():
    rec, manifest = stage_recording("belt-stage", "null", 2)
    out, _ = discover_stage("belt-stage", rec, 2)
    assert abs(out["noise_floor"]["sigma_mm"] / (manifest["noise_um"] / 1000) - 1) < FLOOR_TOL
    assert out["unexplained"] is None and out["verdict"].startswith("nothing missing")


@pytest.mark.parametrize(("scenario", "seed"), [("belt-stage", 3), ("vision-stage", 0)])
def test_a_lagged_thermal_scale_is_found_with_its_lag(scenario, seed):
    """With the lag searched: each axis's thermal expansion named with a ``lag_s``, the lag and
    the coefficient within 3 of their standard errors of the generator's (the lag refined
    between its grid's neighbours, the coefficient's std taking the lag's in; the lag's std
    known to run small), and nothing left above the floor."""
    rec, manifest = stage_recording(scenario, "lagged_thermal", seed)
    truth = manifest["effects"][0]["params"]
    out, _ = discover_stage(scenario, rec, seed)
    lagged = [e for e in out["effects"] if "lag_s" in e["params"]]
    assert {e["axis"] for e in lagged} == {"x", "y"}, out["effects"]
    for e in lagged:
        p, s = e["params"], e["stderr"]
        assert e["name"] == "thermal_expansion"
        # the stated lag std runs about 1.4 times too small (docs/discover.md, the coverage of
        # the new mechanisms): 3 of it, times 1.5
        assert abs(p["lag_s"] - truth["lag_s"]) < 4.5 * s["lag_s"], e
        assert abs(p["ppm_per_k"] - truth["ppm_per_k"]) < 3 * s["ppm_per_k"], e
    assert out["unexplained"] is None, out["verdict"]
