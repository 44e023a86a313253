"""Each command writes to a folder of its own: default folders, a folder of another command's
refused, --force replacing only calibench's files, and a study that never shrinks."""

import concurrent.futures as cf
import json
import shutil
from pathlib import Path

from calibench.scenarios.cli import main
from calibench.scenarios.cli.folders import MARK, owner
from calibench.scenarios.study.montecarlo import run_study

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "belt_stage_paper.csv"


def test_each_command_has_a_folder_of_its_own(tmp_path, monkeypatch):
    """fit's default folder is not run's: real and simulated results never share one."""
    monkeypatch.chdir(tmp_path)
    shutil.copy(EXAMPLE, "r.csv")
    assert main(["fit", "belt-stage", "r.csv"]) == 0
    assert main(["iso230", "r.csv"]) == 2  # r.csv is not an ISO run: the folder is left clean
    fit = tmp_path / "calibench-out" / "belt-stage-fit"
    assert (fit / "fit.json").is_file()
    assert owner(fit) == ("fit", "belt-stage")
    assert not (tmp_path / "calibench-out" / "belt-stage").exists()
    assert not (tmp_path / "calibench-out" / "iso230").exists()


def test_another_command_s_folder_is_refused_unless_forced(tmp_path, capsys):
    out = tmp_path / "o"
    assert main(["fit", "belt-stage", str(EXAMPLE), "--out", str(out)]) == 0
    (out / "notes.txt").write_text("the user's own")
    capsys.readouterr()
    assert main(["discover", "belt-stage", str(EXAMPLE), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "holds the results of `calibench fit belt-stage`" in err and "--force" in err
    assert (out / "fit.json").is_file()  # untouched by the refusal
    assert main(["fit", "vision-stage", str(EXAMPLE), "--out", str(out)]) == 2
    # --force replaces calibench's files, and only those
    assert main(["discover", "belt-stage", str(EXAMPLE), "--out", str(out), "--force"]) == 0
    assert not (out / "fit.json").exists() and (out / "discovery.json").is_file()
    assert (out / "notes.txt").read_text() == "the user's own"
    assert json.loads((out / MARK).read_text()) == {"command": "discover", "scenario": "belt-stage"}


def test_a_folder_made_before_the_mark_is_known_by_its_main_file(tmp_path, capsys):
    out = tmp_path / "o"
    out.mkdir()
    (out / "report.json").write_text("{}")
    assert owner(out) == ("run", None)
    assert main(["fit", "belt-stage", str(EXAMPLE), "--out", str(out)]) == 2
    assert "`calibench run`" in capsys.readouterr().err


def test_a_study_never_shrinks_below_its_journal(tmp_path, capsys):
    """6 finished trials, then --trials 3 into the same folder: the summary keeps all 6 (each
    trial is the same whatever --trials says) and says so; --force starts the study anew."""
    with cf.ThreadPoolExecutor(1) as ex:
        six = run_study("arm-cmm", 6, 5, "analytic", tmp_path, executor=ex, progress=False)
    with cf.ThreadPoolExecutor(1) as ex:
        again = run_study("arm-cmm", 3, 5, "analytic", tmp_path, executor=ex, progress=False)
    assert again["trials"] == six["trials"] == 6
    assert again["parameters"] == six["parameters"]
    assert "holds 6 finished trials" in capsys.readouterr().err
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["trials"] == 6
    argv = ["montecarlo", "arm-cmm", "--trials", "2", "--seed", "5", "--workers", "1"]
    assert main([*argv, "--out", str(tmp_path), "--force"]) == 0
    assert json.loads((tmp_path / "summary.json").read_text())["trials"] == 2
