"""The third suite (issue 61): effects whose mechanism MuJoCo simulates, not a formula
(``sim.concealed.simulated``), on a UR10 probed by a 10 um tracker under heavy-tailed, drifting
and gross reading noise, through ``discover`` blind and scored as the second suite is (the
truth's ``nearest`` candidate on its joint).

- an encoder disc that slipped on its shaft once, at a hard stop: named ``step`` on that joint,
  its moment within 3 of its standard errors and its size within 3 standard errors (or 2 %);
- a gear with play whose friction holds the link where the move left it: named ``backlash`` on
  that joint, the play within 10 % (where gravity beats the friction the play is taken up on
  gravity's side, which no candidate writes), nothing false claimed beside it;
- nulls: nothing claimed."""

import pytest

from calibench.scenarios.discover.suite_unwritten import run_unwritten

ARM = "arm-cmm:ur10"


@pytest.mark.parametrize("seed", range(3))
def test_a_slipped_encoder_is_a_step_at_its_moment(seed):
    r = run_unwritten(ARM, "encoder_slip", seed)
    (truth,) = r.truth
    assert r.detected == 1 and r.false_claims == 0, (r.truth, r.found)
    (step,) = [f for f in r.found if f["name"] == "step"]
    p, std = step["params"], step["stderr"]
    assert abs(p["at_s"] - truth["params"]["t_s"]) <= 3 * std["at_s"], (p, std, truth)
    slip = truth["params"]["slip_urad"]
    assert abs(p["size_urad"] - slip) <= max(3 * std["size_urad"], 0.02 * abs(slip)), (p, std)


@pytest.mark.parametrize("seed", range(3))
def test_a_gear_s_play_held_by_friction_is_backlash_on_its_joint(seed):
    r = run_unwritten(ARM, "gear_play", seed)
    assert r.detected == 1 and r.false_claims == 0, (r.truth, r.found)
    (truth,) = r.truth
    (b,) = [f for f in r.found if f["name"] == "backlash"]
    # the play the link shows, within 10 %: where gravity beats the gear's friction it takes the
    # play up on its own side, which the lost motion's term does not write
    play = truth["params"]["play_urad"]
    assert abs(b["params"]["urad"] - play) <= 0.1 * play, (b, truth)
    # and it carries to the same arm recorded again (rows that chose nothing)
    assert r.fresh.cv_rms_with_effects < 0.5 * r.fresh.cv_rms_scene_model, r.fresh


@pytest.mark.parametrize("seed", range(3))
def test_nothing_is_claimed_on_a_null_under_misspecified_noise(seed):
    r = run_unwritten(ARM, "null", seed)
    assert r.found == [], r.found
