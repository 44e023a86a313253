"""Evidence never chooses and scores on the same rows (issue 35): discovery.json and fit.json say
which rows of which recording chose the model's structure, fitted it and scored it, and a score
on rows that chose the structure is written and printed as in-sample, never as held out."""

import json
import shutil

import numpy as np

from calibench.scenarios.cli import main
from calibench.scenarios.provenance import file_sha256, ranges, rows_in


def test_row_ranges_round_trip():
    rows = np.array([7, 3, 4, 5, 9, 9, 10, 0])
    assert ranges(rows) == [[0, 1], [3, 6], [7, 8], [9, 11]]
    assert rows_in(ranges(rows)).tolist() == [0, 3, 4, 5, 7, 9, 10]
    assert ranges([]) == [] and rows_in([]).size == 0


def _ur10_d(real_data, tmp_path):
    """A copy of ur10_D under another name: a recording is known by its content, not its name."""
    copy = tmp_path / "session.csv"
    shutil.copy(real_data / "ur10_landgraf" / "ur10_D.csv", copy)
    return copy


def _discover(rec, out):
    assert main(["discover", "arm-cmm", str(rec), "--arm", "ur10", "--out", str(out)]) == 0
    return json.loads((out / "discovery.json").read_text())


def _fit(rec, out, *extra):
    args = ["fit", "arm-cmm", str(rec), "--arm", "ur10", "--holdout", "0.3", "--out", str(out)]
    assert main([*args, *extra]) == 0
    return json.loads((out / "fit.json").read_text())


def test_a_score_on_rows_that_chose_the_effects_is_in_sample(real_data, tmp_path, capsys):
    rec = _ur10_d(real_data, tmp_path)
    found = _discover(rec, tmp_path / "d")
    (p,) = found["provenance"]["recordings"]
    assert p["sha256"] == file_sha256(rec)
    # discovery chose on every row it used (all but the rows its screening left out)
    left = {r["row"] for r in found["left_out_rows"]}
    assert set(rows_in(p["rows"]["chose"]).tolist()) == set(range(632)) - left
    fit = _fit(rec, tmp_path / "f", "--effects", str(tmp_path / "d" / "discovery.json"))
    assert "session.csv" not in fit.get("holdout", {})
    judged = fit["in_sample"]["session.csv"]
    assert judged["was"] == "holdout" and "chose the model's structure" in judged["why"]
    assert "in-sample session.csv" in capsys.readouterr().out
    (mine,) = [e for e in fit["provenance"] if e["file"] == "session.csv"]
    scored, chose = rows_in(mine["rows"]["scored"]), rows_in(mine["rows"]["chose"])
    assert len(scored) == judged["samples"] and np.isin(scored, chose).all()


def test_effects_discovered_on_the_training_rows_leave_the_held_out_rows_held_out(
    real_data, tmp_path
):
    rec = _ur10_d(real_data, tmp_path)
    fit = _fit(rec, tmp_path / "f", "--effects", "discover")
    assert "in_sample" not in fit and fit["holdout"]["session.csv"]["samples"] > 100
    assert fit["holdout"]["session.csv"]["kind"].startswith("random rows of a training session")
    (mine,) = fit["provenance"]
    scored, chose = rows_in(mine["rows"]["scored"]), rows_in(mine["rows"]["chose"])
    assert len(scored) and len(chose) and not np.isin(scored, chose).any()
    assert set(rows_in(mine["rows"]["fitted"]).tolist()) <= set(chose.tolist())


def test_effects_that_do_not_say_which_rows_chose_them_score_in_sample(real_data, tmp_path):
    rec = _ur10_d(real_data, tmp_path)
    found = _discover(rec, tmp_path / "d")
    del found["provenance"]
    bare = tmp_path / "bare.json"
    bare.write_text(json.dumps(found))
    fit = _fit(rec, tmp_path / "f", "--effects", str(bare))
    assert "does not say" in fit["in_sample"]["session.csv"]["why"]
    # a test recording is in-sample too, and its plausibility is judged there (it once raised)
    test = tmp_path / "again.csv"
    shutil.copy(rec, test)
    fit = _fit(rec, tmp_path / "g", "--effects", str(bare), "--test", str(test))
    assert fit["in_sample"]["again.csv"]["was"] == "test" and "again.csv" not in fit.get("test", {})


def test_a_recording_the_effects_never_read_is_held_out(real_data, tmp_path):
    """Effects discovered on D alone leave B's held-out rows held out: B never chose."""
    found = tmp_path / "d"
    _discover(real_data / "ur10_landgraf" / "ur10_D.csv", found)
    b = tmp_path / "b.csv"
    shutil.copy(real_data / "ur10_landgraf" / "ur10_B.csv", b)
    fit = _fit(b, tmp_path / "f", "--effects", str(found / "discovery.json"))
    assert "in_sample" not in fit and fit["holdout"]["b.csv"]["samples"] > 300


def test_discover_names_the_joints_gravity_hardly_loads(real_data, tmp_path):
    """discover gives a joint a compliance candidate by fit's own rule, and names the joints it
    does not (their torque said in N m, not rounded to zero)."""
    found = _discover(real_data / "ur10_landgraf" / "ur10_D.csv", tmp_path / "d")
    said = found["not_accepted"]
    assert "carries at most" in said["joint_compliance:joint6"]
    assert "carries at most" not in said.get("joint_compliance:joint2", "")


def test_torques_are_said_to_three_figures_of_the_larger():
    """A joint's torque range in discover's words: three figures, and a value a thousandth of
    the larger said as 0 (not -0.000534, nor the '-0 to -0' of whole numbers)."""
    from calibench.scenarios.arm_cmm.discovery_words import torque_range

    assert torque_range(np.array([-108.2, -0.000534])) == "-108 to 0"
    assert torque_range(np.array([-0.31, 0.2])) == "-0.31 to 0.2"
