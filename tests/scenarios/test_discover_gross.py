"""Gross readings set aside by every discovery that reads samples one by one (the Stewart
platform's poses, the probe scanner's samples: scenarios/discover/gross.py). A scanner recording
with 1 % of its readings 10-30 sigma off (dust under the stylus, a missed count): those samples
are set aside, and the runout is found within 3 of its stated standard errors, as on the same
recording with Gaussian noise, where nothing is set aside."""

import numpy as np

from calibench.scenarios.probe_scanner.discovery import discover_scanner
from calibench.sim.concealed import scanner_recording
from calibench.sim.concealed.noise import OUTLIER_SHARE

SEED = 7067  # before the set-aside its runout came out 4.3 stated std off under outliers


def test_a_scanner_s_gross_readings_are_set_aside():
    for noise in ("gaussian", "outliers"):
        rec, manifest = scanner_recording("runout", SEED, noise=noise)
        out, fig = discover_scanner(rec, 0)
        truth = manifest["effects"][0]["params"]
        (e,) = [e for e in out["effects"] if e["name"] == "runout"]
        z = (e["params"]["amplitude_mm"] - truth["amplitude_mm"]) / e["stderr"]["amplitude_mm"]
        assert abs(z) < 3, (noise, z)
        if noise == "gaussian":
            assert "set_aside" not in out and len(fig["rows_used"][0]) == len(rec)
            continue
        aside = out["set_aside"]["samples"]
        # the readings displaced (OUTLIER_SHARE of them), give or take the few within 8 sigma
        assert 0.7 * OUTLIER_SHARE * len(rec) <= len(aside) <= 1.1 * OUTLIER_SHARE * len(rec)
        assert np.array_equal(np.setdiff1d(np.arange(len(rec)), fig["rows_used"][0]), aside)


def test_a_table_chosen_beside_gross_readings_scores_on_a_fresh_recording():
    """The thin wall's table chosen on a recording with gross readings set aside (its samples
    fewer than the plan's) is fitted on a repeat of the machine (its own readings set aside)
    by the table's angle, and lowers the repeat's held-out RMS."""
    from calibench.scenarios.discover.fresh import score_on_fresh

    out, chosen = discover_scanner(scanner_recording("thin_wall", 7902, noise="outliers")[0], 0)
    assert "set_aside" in out and "nonsmooth" in [e["name"] for e in out["effects"]], out
    again = scanner_recording("thin_wall", 7902, noise="outliers", repeat=1)[0]
    s = score_on_fresh(chosen, discover_scanner(again, 0)[1])
    assert s.not_carried == [] and s.cv_rms_with_effects < s.cv_rms_scene_model, s
