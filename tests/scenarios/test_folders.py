"""Each command writes to a folder of its own: default folders, a folder of another command's
refused, --force replacing only calibench's files (and none where the command is refused), a
user's files by an output's name refused, and a study that never shrinks."""

import concurrent.futures as cf
import fcntl
import json
import shutil
from pathlib import Path

from calibench.scenarios.cli import main
from calibench.scenarios.cli.claims import CLAIM, LOCK, claim, release
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
    # --force with a recording refused: the results it would have replaced are left as they were
    bad = tmp_path / "bad.csv"
    bad.write_text("x_mm,y_mm\n1,2\n")
    before = sorted(p.name for p in out.iterdir())
    assert main(["discover", "belt-stage", str(bad), "--out", str(out), "--force"]) == 2
    assert sorted(p.name for p in out.iterdir()) == before
    assert owner(out) == ("fit", "belt-stage")
    # --force replaces calibench's files, and only those
    assert main(["discover", "belt-stage", str(EXAMPLE), "--out", str(out), "--force"]) == 0
    assert not (out / "fit.json").exists() and (out / "discovery.json").is_file()
    assert (out / "notes.txt").read_text() == "the user's own"
    assert json.loads((out / MARK).read_text()) == {"command": "discover", "scenario": "belt-stage"}
    assert not (out / CLAIM).exists()


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


def test_a_user_s_files_by_an_output_s_name_are_refused_even_with_force(tmp_path, capsys):
    """A paper's data folder holds x_axis_error_mm.csv, which a belt-stage run also writes: no
    command marked the folder, so the file is the user's, and neither a run nor --force touches
    it."""
    data = tmp_path / "paper"
    data.mkdir()
    (data / "x_axis_error_mm.csv").write_text("the paper's table\n")
    for force in ([], ["--force"]):
        argv = ["run", "belt-stage", "--no-rrd", "--out", str(data), *force]
        assert main(argv) == 2
        err = capsys.readouterr().err
        assert "x_axis_error_mm.csv" in err and "written by no calibench command" in err
        assert (data / "x_axis_error_mm.csv").read_text() == "the paper's table\n"
        assert sorted(p.name for p in data.iterdir()) == ["x_axis_error_mm.csv"]


def test_only_calibench_out_itself_is_exempt_from_the_user_s_files_check(tmp_path, monkeypatch):
    """calibench-out is calibench's own (a folder there with a stray figure is an old run's), but
    a path that only passes through it is not."""
    monkeypatch.chdir(tmp_path)
    for folder in ("calibench-out/old", "paper"):
        Path(folder).mkdir(parents=True)
        Path(folder, "figure.png").write_text("made before the mark")
    assert main(["run", "stewart", "--no-rrd", "--out", "calibench-out/../paper"]) == 2
    assert Path("paper/figure.png").read_text() == "made before the mark"
    assert main(["run", "stewart", "--no-rrd", "--out", str(tmp_path / "calibench-out/old")]) == 0


def test_the_folder_is_marked_before_any_output_and_unmarked_on_bad_input(tmp_path, capsys):
    """An interrupted first run's folder holds the mark and some outputs: it is calibench's, and
    the same command (or --force) takes it again. A command refused as bad input leaves no mark."""
    out = tmp_path / "o"
    out.mkdir()
    (out / MARK).write_text(json.dumps({"command": "fit", "scenario": "belt-stage"}) + "\n")
    (out / "fit.png").write_text("half written")  # the run was cut off before fit.json
    assert owner(out) == ("fit", "belt-stage")
    assert main(["fit", "belt-stage", str(EXAMPLE), "--out", str(out)]) == 0
    assert (out / "fit.json").is_file()
    bad = tmp_path / "bad.csv"
    bad.write_text("x_mm,y_mm\n1,2\n")
    empty = tmp_path / "e"
    empty.mkdir()
    capsys.readouterr()
    assert main(["fit", "belt-stage", str(bad), "--out", str(empty)]) == 2
    assert "calibench:" in capsys.readouterr().err
    assert list(empty.iterdir()) == []  # no claim left on it
    assert main(["fit", "belt-stage", str(bad), "--out", str(tmp_path / "new")]) == 2
    assert not (tmp_path / "new").exists()  # made for the command, removed again


def test_one_command_writes_in_a_folder_at_a_time(tmp_path, capsys):
    """While another command holds the folder (its lock), a second is refused in one line and
    leaves the first's mark as it was (a refused command used to take the mark of a study that
    had not written its journal yet); once the first is done the second runs."""
    out = tmp_path / "o"
    out.mkdir()
    (out / MARK).write_text(json.dumps({"command": "fit", "scenario": "belt-stage"}) + "\n")
    with open(out / LOCK, "a") as held:
        fcntl.flock(held, fcntl.LOCK_EX | fcntl.LOCK_NB)
        assert main(["fit", "belt-stage", str(EXAMPLE), "--out", str(out)]) == 2
        assert "another calibench command is writing in this folder" in capsys.readouterr().err
        assert owner(out) == ("fit", "belt-stage") and not (out / "fit.json").exists()
    assert main(["fit", "belt-stage", str(EXAMPLE), "--out", str(out)]) == 0


def test_a_refused_command_leaves_no_mark_on_a_folder_known_by_its_main_file(tmp_path):
    """A study's folder made before the mark (its journal only): another scenario's study is
    refused, and the folder is not left marked as that scenario's (which would lock the study's
    own resumption out)."""
    out = tmp_path / "o"
    args = ["--trials", "2", "--fidelity", "analytic", "--workers", "1", "--out", str(out)]
    assert main(["montecarlo", "belt-stage", *args]) == 0
    (out / MARK).unlink()
    assert owner(out) == ("montecarlo", None)
    assert main(["montecarlo", "stewart", *args]) == 2
    assert not (out / MARK).exists() and not (out / CLAIM).exists()
    assert main(["montecarlo", "belt-stage", *args[:1], "3", *args[2:]]) == 0


def test_a_crash_under_force_puts_the_replaced_results_back(tmp_path, monkeypatch):
    """A command that crashes having written only its traceback wrote no results: the fit it was
    to replace is back, with its mark, beside error.log."""
    from calibench.scenarios.cli import verbs

    out = tmp_path / "o"
    assert main(["fit", "belt-stage", str(EXAMPLE), "--out", str(out)]) == 0
    fit = (out / "fit.json").read_text()

    def crash(args):
        raise RuntimeError("a defect of calibench's")

    monkeypatch.setattr(verbs, "discover", crash)
    assert main(["discover", "belt-stage", str(EXAMPLE), "--out", str(out), "--force"]) == 3
    assert (out / "fit.json").read_text() == fit and (out / "error.log").is_file()
    assert owner(out) == ("fit", "belt-stage") and not (out / CLAIM).exists()
    # a crash in a new folder leaves its traceback alone there, which blocks no later command
    new = tmp_path / "n"
    assert main(["discover", "belt-stage", str(EXAMPLE), "--out", str(new)]) == 3
    assert [p.name for p in new.iterdir()] == ["error.log"]
    assert main(["fit", "belt-stage", str(EXAMPLE), "--out", str(new)]) == 0


def test_a_claim_left_by_a_command_killed_outright_is_settled_by_the_next(tmp_path):
    """A `discover --force` killed outright (no release) left its claim: the fit's results set
    aside, the folder marked as discover's, no discovery written. The next command settles it
    as the release would have: the fit's results and mark are back, so `fit` takes the folder."""
    out = tmp_path / "o"
    assert main(["fit", "belt-stage", str(EXAMPLE), "--out", str(out)]) == 0
    mark = (out / MARK).read_text()
    (out / CLAIM).mkdir()
    present = [p.name for p in out.iterdir() if p.name not in (LOCK, CLAIM)]
    state = {"mark": mark, "found": {}, "present": present}
    (out / CLAIM / "claim.json").write_text(json.dumps(state))
    for path in list(out.iterdir()):
        if path.name not in (LOCK, CLAIM):
            path.rename(out / CLAIM / path.name)
    (out / MARK).write_text(json.dumps({"command": "discover", "scenario": "belt-stage"}) + "\n")
    assert main(["fit", "belt-stage", str(EXAMPLE), "--out", str(out)]) == 0
    assert owner(out) == ("fit", "belt-stage") and not (out / CLAIM).exists()


def test_a_forced_study_interrupted_before_its_first_trial_keeps_the_old_one(tmp_path, monkeypatch):
    """`montecarlo --force` over a finished study, interrupted once it had described the new
    study (study.json, an empty journal) but before any trial finished: no result was written,
    so the old study is back whole, and resumes."""
    from calibench.scenarios.study import montecarlo

    out = tmp_path / "o"
    args = ["montecarlo", "belt-stage", "--fidelity", "analytic", "--workers", "1"]
    assert main([*args, "--trials", "3", "--out", str(out)]) == 0
    before = {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()}

    def interrupted(executor, scenario, seed, fidelity, out_dir, *rest, **kw):
        (out_dir / "trials.jsonl").touch()
        raise KeyboardInterrupt

    monkeypatch.setattr(montecarlo, "_run_todo", interrupted)
    assert main([*args, "--trials", "2", "--seed", "9", "--out", str(out), "--force"]) == 130
    assert {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()} == before
    monkeypatch.undo()
    assert main([*args, "--trials", "4", "--out", str(out)]) == 0  # the old study, resumed


def test_a_restore_cut_off_midway_is_finished_by_the_next_command(tmp_path, capsys):
    """A release killed halfway through putting a fit's results back (fit.json back, fit.png and
    the mark still set aside): the results back are the ones found, not new ones, so the next
    command, even one refused, finishes the restore rather than discarding the rest."""
    out = tmp_path / "o"
    assert main(["fit", "belt-stage", str(EXAMPLE), "--out", str(out)]) == 0
    mark = (out / MARK).read_text()
    names = sorted(p.name for p in out.iterdir() if p.name not in (LOCK, MARK))
    found = {
        n: [(out / n).lstat().st_size, (out / n).lstat().st_mtime_ns, (out / n).lstat().st_ino]
        for n in ("fit.json", "fit.png", "residuals.csv")
        if (out / n).exists()
    }
    (out / CLAIM).mkdir()
    state = {"mark": mark, "found": found, "present": [*names, MARK]}
    (out / CLAIM / "claim.json").write_text(json.dumps(state))
    for name in names:
        if name != "fit.json":
            (out / name).rename(out / CLAIM / name)
    (out / MARK).rename(out / CLAIM / MARK)
    (out / MARK).write_text(json.dumps({"command": "discover", "scenario": "belt-stage"}))
    assert main(["iso230", str(EXAMPLE), "--out", str(out)]) == 2  # refused: holds a fit
    assert "holds the results of `calibench fit belt-stage`" in capsys.readouterr().err
    assert sorted(p.name for p in out.iterdir() if p.name not in (LOCK, MARK)) == names


def test_a_forced_run_cut_off_before_its_report_keeps_the_old_results(tmp_path, monkeypatch):
    """A run writes its figure and recording before report.json: cut off between them (here by
    a crash in the report's writing) it wrote parts, no results, so the fit it was to replace is
    back and the parts are gone; a stray file where the claim's record goes is no claim's."""
    from calibench.scenarios.report import Report

    out = tmp_path / "o"
    assert main(["fit", "belt-stage", str(EXAMPLE), "--out", str(out)]) == 0
    before = sorted(p.name for p in out.iterdir())
    (out / CLAIM).write_text("not a claim")

    def cut_off(self, out_dir):
        raise RuntimeError("cut off before report.json")

    monkeypatch.setattr(Report, "write", cut_off)
    assert main(["run", "stewart", "--out", str(out), "--force"]) == 3
    assert sorted(p.name for p in out.iterdir()) == sorted([*before, "error.log"])
    assert owner(out) == ("fit", "belt-stage")


def test_a_second_command_in_its_own_folder_says_what_it_replaced(tmp_path, capsys):
    """A second fit replaces the first's results in one line naming them, never silently; one
    refused says nothing (it replaced nothing), and --force names the other command's."""
    out = tmp_path / "o"
    argv = ["fit", "belt-stage", str(EXAMPLE), "--out", str(out)]
    assert main(argv) == 0
    assert "replaced" not in capsys.readouterr().err  # a first fit replaces nothing
    assert main(argv) == 0
    lines = [ln for ln in capsys.readouterr().err.splitlines() if "replaced" in ln]
    assert len(lines) == 1
    assert "replaced the former results of `calibench fit belt-stage` (fit.json of " in lines[0]
    bad = tmp_path / "bad.csv"
    bad.write_text("x_mm,y_mm\n1,2\n")
    assert main(["fit", "belt-stage", str(bad), "--out", str(out)]) == 2
    assert "replaced" not in capsys.readouterr().err
    assert main(["fit", "vision-stage", str(EXAMPLE), "--out", str(out), "--force"]) == 0
    assert "replaced the former results of `calibench fit belt-stage`" in capsys.readouterr().err
    # a study resumed extends its own results (its summary rewritten): nothing said
    for summary in ("{}", '{"trials": 2}'):
        held: list = []
        claim(tmp_path / "s", "montecarlo", "arm-cmm", False, held)
        (tmp_path / "s" / "summary.json").write_text(summary)
        release(held)
    assert "replaced" not in capsys.readouterr().err
