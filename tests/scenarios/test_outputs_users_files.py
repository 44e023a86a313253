"""Issue 62: a user's files never replaced nor written through a link, and the environment's faults
(a memory limit, an encoding, a lost Dask cluster, commands started together) said in one line.
tests/bad_input/cli.py holds the cases' one-line answers; these check what each leaves behind."""

from __future__ import annotations

import concurrent.futures as cf
import json
import os
import subprocess
import sys
import time
import warnings
from pathlib import Path

import pytest

from calibench.errors import BadInput
from calibench.scenarios.cli import main
from calibench.scenarios.cli.folders import MARK, writable_folder

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "belt_stage_paper.csv"


def _one_line(capsys) -> str:
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    return err


def test_a_link_at_an_output_s_name_is_never_written_through(tmp_path, capsys):
    """Issue 62 item 2: a link at fit.json wrote the fit into the user's file elsewhere; a dangling
    one created its target; a lock link an empty file. Unmarked: refused; in calibench's own
    folder: the link replaced by the result, its target untouched."""
    v = tmp_path / "v"
    v.mkdir()
    (v / "p").write_text("PRECIOUS\n")
    d = tmp_path / "d"
    d.mkdir()
    for planted, target in ((d / "fit.json", v / "p"), (d / ".calibench.lock", v / "lock")):
        planted.symlink_to(target)
        assert main(["fit", "belt-stage", str(EXAMPLE), "--out", str(d)]) == 2
        _one_line(capsys)
        assert planted.is_symlink()
        planted.unlink()
    (d / "fit.json").symlink_to(v / "none")
    assert main(["fit", "belt-stage", str(EXAMPLE), "--out", str(d)]) == 2
    assert sorted(p.name for p in v.iterdir()) == ["p"] and (v / "p").read_text() == "PRECIOUS\n"
    (d / "fit.json").unlink()
    assert main(["fit", "belt-stage", str(EXAMPLE), "--out", str(d)]) == 0
    (d / "fit.json").unlink()
    (d / "fit.json").symlink_to(v / "p")
    assert main(["fit", "belt-stage", str(EXAMPLE), "--out", str(d)]) == 0
    assert not (d / "fit.json").is_symlink() and json.loads((d / "fit.json").read_text())
    assert (v / "p").read_text() == "PRECIOUS\n"


def test_a_user_s_error_log_survives_force_and_a_crash(tmp_path, monkeypatch, capsys):
    """Issue 62 item 6: a user's error.log was deleted by --force and overwritten by a crash's
    traceback. Calibench's own error.log is known by its first line, never by its name."""
    from calibench.scenarios import stage_fit

    monkeypatch.chdir(tmp_path)
    out = Path("calibench-out/belt-stage-fit")
    assert main(["fit", "belt-stage", str(EXAMPLE)]) == 0
    (out / "error.log").write_text("my own notes\n")
    assert main(["discover", "belt-stage", str(EXAMPLE), "--out", str(out), "--force"]) == 0
    assert (out / "error.log").read_text() == "my own notes\n"

    def broken(*a, **k):
        raise RuntimeError("a defect")

    monkeypatch.setattr(stage_fit, "fit_recording", broken)
    capsys.readouterr()
    assert main(["fit", "belt-stage", str(EXAMPLE), "--out", str(out), "--force"]) == 3
    assert "calibench-error.log" in _one_line(capsys)
    assert (out / "error.log").read_text() == "my own notes\n"
    log = (out / "calibench-error.log").read_text()
    assert log.startswith("calibench: internal error") and "a defect" in log
    assert (out / "discovery.json").is_file()  # the crash wrote no results: the former are back


def test_an_input_is_never_an_output(tmp_path, monkeypatch):
    """`fit arm-cmm calibench-out/arm-cmm-fit/residuals.csv` replaced its own input; `--twin` at
    the folder's discovery.json or mark lost the twin or corrupted the mark."""
    monkeypatch.chdir(tmp_path)
    folder = Path("calibench-out/arm-cmm-fit")
    folder.mkdir(parents=True)
    (folder / "residuals.csv").write_text("mine\n")
    (folder / "also.csv").hardlink_to(folder / "residuals.csv")
    for given in (folder / "residuals.csv", folder / "also.csv"):
        assert main(["fit", "arm-cmm", str(given)]) == 2
    assert (folder / "residuals.csv").read_text() == "mine\n"
    assert not (folder / MARK).exists()


def test_a_mark_of_the_wrong_kind_is_one_line(tmp_path, capsys):
    """A mark that is a pipe (read, it would block for ever) or names a scenario by a number."""
    for make in (os.mkfifo, lambda p: Path(p).write_text('{"command": "fit", "scenario": 5}')):
        d = tmp_path / f"d{len(list(tmp_path.iterdir()))}"
        d.mkdir()
        make(d / MARK)
        assert main(["fit", "belt-stage", str(EXAMPLE), "--out", str(d)]) == 2
        assert "does not say which command wrote" in _one_line(capsys)


def test_commands_started_together_each_test_their_own_name(tmp_path):
    """Issue 62 item 10: 3 of 150 racers were told "No such file or directory" as another removed
    the write test's one shared name."""
    with cf.ThreadPoolExecutor(8) as ex:
        list(ex.map(lambda _: writable_folder(tmp_path / "o"), range(400)))
    assert list((tmp_path / "o").iterdir()) == []


def test_a_study_refused_for_its_scheduler_leaves_no_folder(tmp_path, capsys):
    """Issue 62 item 10: a montecarlo refused for a bad --scheduler left .study.lock in the folder
    it made."""
    out = tmp_path / "o"
    argv = ["montecarlo", "belt-stage", "--trials", "2", "--scheduler", "no address"]
    assert main([*argv, "--out", str(out)]) == 2
    assert "not a scheduler's address" in _one_line(capsys)
    assert not out.exists()


def test_library_warnings_before_bad_input_are_not_said(tmp_path, monkeypatch, capsys):
    """Issue 62 item 10: numpy's warnings printed before bad input's one line."""
    from calibench.scenarios import stage_fit

    def noisy(*a, **k):
        warnings.warn("Mean of empty slice", RuntimeWarning, stacklevel=1)
        raise BadInput("the recording has one station")

    def shown(message, category, filename, lineno, file=None, line=None):
        print(f"{filename}:{lineno}: {category.__name__}: {message}", file=sys.stderr)

    monkeypatch.setattr(stage_fit, "load_stage_csv", noisy)
    with warnings.catch_warnings():  # as a console shows them (pytest records them instead)
        warnings.simplefilter("always")
        warnings.showwarning = shown
        assert main(["fit", "belt-stage", str(EXAMPLE), "--out", str(tmp_path / "o")]) == 2
    assert "one station" in _one_line(capsys)


def test_a_memory_error_is_one_line(tmp_path, monkeypatch, capsys):
    from calibench.scenarios import stage_fit

    def huge(*a, **k):
        raise MemoryError

    monkeypatch.setattr(stage_fit, "fit_recording", huge)
    assert main(["fit", "belt-stage", str(EXAMPLE), "--out", str(tmp_path / "o")]) == 2
    assert "out of memory" in _one_line(capsys)
    assert not (tmp_path / "o").exists()


def test_an_ascii_console_takes_a_folder_s_name_in_another_script(tmp_path):
    """Issue 62 item 7: PYTHONIOENCODING=ascii and a non-ASCII --out failed at the last line."""
    env = {**os.environ, "PYTHONIOENCODING": "ascii"}
    out = tmp_path / "résultats"
    got = subprocess.run(
        [sys.executable, "-m", "calibench.scenarios.cli", "fit", "belt-stage", str(EXAMPLE)]
        + ["--out", str(out)],
        capture_output=True,
        text=True,
        env=env,
    )
    assert got.returncode == 0, got.stderr
    assert "r\\xe9sultats" in got.stdout and (out / "fit.json").is_file()


def test_a_lost_dask_cluster_is_said_not_waited_for(monkeypatch):
    """Issue 62 items 7 and 10: a scheduler killed mid-study was 36 lines and exit 3 (a cancelled
    future); a cluster without workers left the study waiting silently."""
    from calibench.scenarios.study import executor

    fut: cf.Future = cf.Future()
    fut.cancel()
    with pytest.raises(BadInput, match="scheduler stopped"):
        executor.cluster_result(fut)

    class Cluster:
        workers_now = staticmethod(lambda: 0)

    monkeypatch.setattr(executor, "NO_WORKERS_S", 0.05)
    watch = executor.WorkersGone(Cluster())
    watch.check()  # the first sight of none starts the clock
    time.sleep(0.1)
    with pytest.raises(BadInput, match="no worker left"):
        watch.check()
    executor.WorkersGone(cf.ThreadPoolExecutor(1)).check()  # a local pool: never watched
