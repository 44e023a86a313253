"""The third suite (issue 61): effects whose mechanism MuJoCo simulates, not a formula
(``sim.concealed.simulated``), on a UR10 probed by a 10 um tracker under heavy-tailed, drifting
and gross reading noise, through ``discover`` blind and scored as the second suite is (the
truth's ``nearest`` candidate on its joint).

- an encoder disc that slipped on its shaft once, at a hard stop: named ``step`` on that joint,
  its moment within 3 of its standard errors and its size within 3 standard errors (or 2 %);
- a gear with play whose friction holds the link where the move left it: named ``backlash`` on
  that joint, the play within 10 % (where gravity beats the friction the play is taken up on
  gravity's side, which no candidate writes), nothing false claimed beside it;
- nulls: nothing claimed;
- a stage's scales heated through the machine's heat capacities (a network integrated in time,
  not the candidates' first-order lag) as the room warms, under heavy-tailed, drifting, gross
  and quantised reading noise: named ``thermal_expansion`` on both axes, its coefficient within
  3 standard errors or 15 % (the lag's single time constant absorbs what the network's second
  one adds: up to 10 % on these cases) and carried to the same stage recorded again;
- a Stewart leg whose brakeless motor warms its tube by the copper loss of holding its load
  (MuJoCo's statics, pose by pose; no temperature logged for it): named ``thermal_drift`` on
  that leg, 4 of 4; beside it, on one of the four, the part of the growth that goes with the
  leg's length is taken for lost motion (the suite's figure allows one recording with a false
  claim per instrument; docs/discover.md says why);
- a probe scanner's stylus mount warmed through the probe's column as the room warms (a network
  integrated in time, its delay longer than the recording): named ``thermal_drift`` under
  heavy-tailed, gross and quantised readings; under drifting readings (the suite's seed 1) the
  reading's own drift and the mount's warming are alike held out and nothing is named, which
  the suite's table counts as a miss;
- quantised readings (counts of 3 sigma) on a null of each instrument: nothing claimed, and
  where the recording gives a floor it is the reading's whole scatter, not the repeats'."""

import pytest

from calibench.scenarios.discover.suite_unwritten import run_unwritten
from calibench.sim.concealed.noise import THIRD_SUITE_NOISES

ARM = "arm-cmm:ur10"
STAGES = ("belt-stage", "vision-stage")


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


@pytest.mark.parametrize("scenario", STAGES)
@pytest.mark.parametrize("seed", range(4))
def test_a_scale_heated_through_its_capacities_is_thermal_expansion(scenario, seed):
    r = run_unwritten(scenario, "heated_scale", seed)
    assert r.detected == 2 and r.false_claims == 0, (r.truth, r.found)
    for truth in r.truth:
        (f,) = [
            f for f in r.found if f["name"] == "thermal_expansion" and f["axis"] == truth["axis"]
        ]
        k = truth["params"]["ppm_per_k"]
        std = f["stderr"]["ppm_per_k"]
        assert abs(f["params"]["ppm_per_k"] - k) <= max(0.15 * k, 3 * std), (f, truth)
    assert r.fresh.cv_rms_with_effects < 0.6 * r.fresh.cv_rms_scene_model, r.fresh


def test_a_leg_warmed_by_its_motor_is_a_drift_on_that_leg():
    results = [run_unwritten("stewart", "heated_leg", seed) for seed in range(4)]
    assert [r.detected for r in results] == [1, 1, 1, 1], [(r.truth, r.found) for r in results]
    assert sum(r.false_claims > 0 for r in results) <= 1, [r.found for r in results]
    for r in results:  # what is claimed beside it is on the warmed leg, where the heat acts
        (truth,) = r.truth
        assert all(f["params"].get("leg") == truth["params"]["leg"] for f in r.found), r.found


@pytest.mark.parametrize("seed", (0, 2, 3))
def test_a_probe_mount_warmed_through_its_column_is_a_thermal_drift(seed):
    noise = THIRD_SUITE_NOISES[seed % len(THIRD_SUITE_NOISES)]
    r = run_unwritten("probe-scanner", "heated_mount", seed, noise=noise)
    assert r.below_floor == 0, (r.truth, r.cv_before)
    assert r.detected == 1 and r.false_claims == 0, (r.truth, r.found)
    assert r.fresh.cv_rms_with_effects < r.fresh.cv_rms_scene_model, r.fresh


def test_a_mount_warmed_too_little_to_pass_the_floor_is_not_called_nothing_missing():
    # seed 1: the column lags the air by 103 s over a recording of 80 s, so the mount moves the
    # zero by 0.9 um RMS under 2.5 um of reading noise and as much of a drift: removed whole, it
    # would cut the held-out RMS by 4 %, under the selection's 10 %. Missed by the rule, and the
    # verdict must say something is left rather than that nothing is
    r = run_unwritten("probe-scanner", "heated_mount", 1, noise=THIRD_SUITE_NOISES[1])
    assert r.below_floor == 1 and r.detected_below == 0, (r.truth, r.cv_before)
    assert r.false_claims == 0, r.found
    assert not r.verdict.startswith("nothing missing"), r.verdict


@pytest.mark.parametrize("scenario", (ARM, "stewart", "probe-scanner") + STAGES)
def test_nothing_is_claimed_on_quantised_readings(scenario):
    r = run_unwritten(scenario, "null", 0, noise="quantised")
    assert r.found == [], r.found


@pytest.mark.parametrize("scenario", STAGES)
def test_the_floor_of_quantised_readings_is_their_whole_scatter(scenario):
    from calibench.scenarios.discover.suite import recorded, searched

    rec, manifest = recorded(scenario, "null", 11, noise="quantised")
    out, _ = searched(scenario, rec, 11)
    sigma = manifest["noise_um"] / 1000  # the whole scatter: the count's and the half sigma
    # 6000-odd successive pairs give their standard deviation within 3 % (three of its errors);
    # the rest of the 10 % is what changes between successive readings (a pass's offset)
    assert abs(out["noise_floor"]["sigma_mm"] / sigma - 1.0) < 0.1, out["noise_floor"]
    assert out["verdict"].startswith("nothing missing"), out["verdict"]
