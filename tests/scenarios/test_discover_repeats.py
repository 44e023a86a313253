"""Repeats are grouped by what was commanded (issue 36): a Stewart platform's poses by their
legs' readings, not by the tracker's measured pose, whose noise would split them."""

import dataclasses

import numpy as np
from scipy.spatial.transform import Rotation

from calibench.scenarios.stewart.discovery import discover_stewart, stations
from calibench.sim.concealed import stewart_recording


def test_a_null_platform_under_a_noisy_tracker_is_judged_at_its_noise():
    """A null recording (every pose visited twice) seen by a tracker with 15 um and 50 urad of
    pose noise: the repeats group as they do without that noise (the visits approached the same
    way by every leg, a fifth of them here, pair up; the others are not repeats), the
    repeatability is the scatter the tracker's noise puts on the legs' residuals (so the RMS in
    discover's folds, where only the scene model was chosen, is within 15 % of it), and the
    verdict is not "unexplained"."""
    rec, _ = stewart_recording("null", 5000)
    rng = np.random.default_rng(9)
    turn = Rotation.from_rotvec(rng.normal(0, 5e-5, (len(rec), 3)))
    noisy = dataclasses.replace(
        rec,
        t_mm=rec.t_mm + rng.normal(0, 0.015, rec.t_mm.shape),
        R=(turn * Rotation.from_matrix(rec.R)).as_matrix(),
    )
    groups = stations(noisy, 0.0057)
    np.testing.assert_array_equal(groups, stations(rec, 0.0057))  # the tracker splits none
    assert np.bincount(groups).max() == 2 and len(np.unique(groups)) <= 0.9 * len(rec)
    out, _ = discover_stewart(noisy, 0)
    sigma = out["noise"]["legs"]["repeatability_mm"]
    assert sigma is not None and sigma > 0.01  # the tracker's scatter, not only the legs' 1 um
    assert out["fit"]["cv_rms_final"] < 1.15 * sigma
    assert not out["verdict"].startswith("unexplained")
    assert [e["name"] for e in out["effects"]] == ["geometry"]


def test_every_commanded_repeat_pairs_up_at_the_default_tolerance():
    """The generator visits each pose again in reverse order: the visits approached the same way
    by every leg are the true repeats (counted from the plan, not from the readings).
    discover's repeatability rests on exactly those pairs, six station pairs each (its dof): a
    tolerance tighter than the readings' noise splits some, one looser merges none here."""
    rec, _ = stewart_recording("null", 1)
    n = len(rec) // 2
    pairs = int(np.all(rec.direction[:n] == rec.direction[::-1][:n], axis=1).sum())
    assert pairs >= 20
    out, _ = discover_stewart(rec, 0)
    assert out["noise"]["legs"]["dof"] == 6 * pairs
