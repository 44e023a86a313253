"""A structure discover chose, scored on a fresh recording of the same machine
(scenarios/discover/fresh.py): rows that chose nothing."""

import numpy as np

from calibench.scenarios.discover.fresh import score_on_fresh
from calibench.scenarios.probe_scanner.discovery import discover_scanner
from calibench.sim.concealed import scanner_recording


def test_scored_on_its_own_recording_it_is_the_selections_figure():
    """The same folds, the same fits: on the recording that chose it, the score is discover's
    own cv_rms_nominal and cv_rms_final, to rounding."""
    rec, _ = scanner_recording("runout", 31)
    out, fig = discover_scanner(rec, 0)
    assert [e["name"] for e in out["effects"]] == ["runout"], out["effects"]
    s = score_on_fresh(fig, fig)
    assert np.isclose(s.cv_rms_scene_model, out["fit"]["cv_rms_nominal"], rtol=1e-10)
    assert np.isclose(s.cv_rms_with_effects, out["fit"]["cv_rms_final"], rtol=1e-10)
    assert s.rows == len(rec) and s.not_carried == []


def test_a_fresh_recording_is_predicted_to_its_noise_and_a_table_carries_by_angle():
    """A runout chosen on one recording, fitted and held out on a repeat of the same machine
    (its noise fresh): the fresh rows are left at what the fresh recording's own discovery
    leaves, within the RMS's sampling error (relative std 1 / sqrt(2 n) over n rows; 5 of
    them), far below the scene model's. A nick's table is a law of the table's angle (the nick
    sits on the artefact): it carries to any recording that logs the angle. On a repeat of the
    machine it lowers the held-out RMS; on a recording of three turns, which draws another
    machine (its nick elsewhere), it gains nothing (a nick's depth over its width would take
    the RMS down by 5 %)."""
    rec, manifest = scanner_recording("runout", 31)
    _, chosen = discover_scanner(rec, 0)
    again, m2 = scanner_recording("runout", 31, repeat=1)
    assert m2["effects"] == manifest["effects"]  # the same machine
    assert not np.array_equal(again.rho_mm, rec.rho_mm)  # recorded again
    own, fresh = discover_scanner(again, 0)
    s = score_on_fresh(chosen, fresh)
    tol = 5 / np.sqrt(2 * s.rows)
    assert abs(s.cv_rms_with_effects / own["fit"]["cv_rms_final"] - 1) < tol, (s, own["fit"])
    assert s.cv_rms_with_effects < 0.6 * s.cv_rms_scene_model, s

    rec, manifest = scanner_recording("bump", 32)
    out, chosen = discover_scanner(rec, 0)
    assert "nonsmooth" in [e["name"] for e in out["effects"]], out["effects"]
    other, m3 = scanner_recording("bump", 32, turns=3, repeat=1)
    assert m3["effects"] != manifest["effects"]
    s = score_on_fresh(chosen, discover_scanner(other, 0)[1])
    assert s.not_carried == [] and s.cv_rms_with_effects > 0.99 * s.cv_rms_scene_model, s
    _, same_plan = discover_scanner(scanner_recording("bump", 32, repeat=1)[0], 0)
    s = score_on_fresh(chosen, same_plan)
    assert s.not_carried == [] and s.cv_rms_with_effects < s.cv_rms_scene_model, s
