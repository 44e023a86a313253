"""A long command's progress (scenarios/progress.py): a plain line at least every 30 s off a
terminal, the first with how long is left once a step says it, the final line once; one bar on a
terminal, which a study's workers never draw into; the command's own output unchanged."""

import concurrent.futures as cf
import fcntl
import io
import os
import pty
import re
import select
import struct
import subprocess
import sys
import termios
import time
from pathlib import Path

import pytest

from calibench.scenarios import progress
from calibench.scenarios.cli.entry import main


@pytest.fixture
def clock(monkeypatch):
    """A clock the test moves (the heartbeat thread off: the lines depend on the test alone)."""
    now = [1000.0]
    monkeypatch.setattr(progress, "CLOCK", lambda: now[0])
    monkeypatch.setattr(progress, "HEARTBEAT", False)
    monkeypatch.delenv(progress.ENV, raising=False)
    return now


def test_a_log_gets_the_estimate_first_then_a_line_every_interval_and_the_end_once(clock):
    log = io.StringIO()  # not a terminal: plain lines
    with progress.Progress("study", stream=log) as p:
        p.expect(4, "trials", weights=[1, 1, 2, 2])
        clock[0] += 5
        p.advance()  # within the grace: a short command says nothing
        assert log.getvalue() == ""
        clock[0] += 7
        # past the grace, the time left known: the first line says it (the first trial's 5 s
        # a weight, 25 s for the rest, 7 of them spent)
        p.step("trial 2")
        assert log.getvalue().splitlines() == [
            "calibench: study: 1/4 trials, trial 2, 12 s; about 18 s left"
        ]
        clock[0] += 29
        p.stage("calibrating")
        assert len(log.getvalue().splitlines()) == 1  # not yet 30 s since the last
        clock[0] += 1
        p.tick()  # the second trial is slower than the first: its own time says the pace
        assert log.getvalue().splitlines()[-1] == (
            "calibench: study: 1/4 trials, trial 2: calibrating, 42 s; about 3 min 30 s left"
        )
        clock[0] += 100
        p.advance(3)
    lines = log.getvalue().splitlines()
    assert lines[-2:] == [
        "calibench: study: 4/4 trials, 2 min 22 s",
        "calibench: study: done, 4 trials, 2 min 22 s",
    ]
    assert sum("done" in x for x in lines) == 1


def test_a_command_shorter_than_the_grace_says_nothing_and_a_failed_one_no_end(clock):
    log = io.StringIO()
    with progress.Progress("run", stream=log):
        clock[0] += progress.GRACE_S - 1
    assert log.getvalue() == ""
    with pytest.raises(KeyboardInterrupt), progress.Progress("run", stream=log):
        clock[0] += 60
        progress.stage("rendering")  # the code the command calls reports to its progress
        raise KeyboardInterrupt
    assert log.getvalue().splitlines() == ["calibench: run: rendering, 1 min 00 s"]


def test_the_heartbeat_says_a_line_while_one_step_runs_for_minutes(clock, monkeypatch):
    monkeypatch.setattr(progress, "HEARTBEAT", True)
    log = io.StringIO()
    with progress.Progress("fit arm-cmm", estimate_s=100, stream=log):
        progress.stage("calibrating")
        clock[0] += 31  # the documented estimate is known from the start
        deadline = time.monotonic() + 10
        while not log.getvalue() and time.monotonic() < deadline:
            time.sleep(0.05)
        assert log.getvalue().splitlines() == [
            "calibench: fit arm-cmm: calibrating, 31 s; about 1 min 09 s left"
        ]
        clock[0] += 31
        while len(log.getvalue().splitlines()) < 2 and time.monotonic() < deadline:
            time.sleep(0.05)
        assert log.getvalue().splitlines()[1] == (
            "calibench: fit arm-cmm: calibrating, 1 min 02 s; about 38 s left"
        )


def test_leave_one_out_off_a_terminal_says_each_fold_and_its_output_is_unchanged(
    clock, tmp_path, capsys, monkeypatch
):
    """`fit arm-cmm --leave-one-out` (its fits replaced by one that takes 45 s of the test's
    clock): a line per fold, the first with the time left, the final line once; stdout as
    without progress."""
    from calibench.scenarios.arm_cmm import sessions

    paths = []
    for name in ("a.csv", "b.csv", "c.csv"):
        paths.append(tmp_path / name)
        paths[-1].write_text("x")

    def fit(train, arm, tests, new_frame, *rest):
        with progress.staged("calibrating"):
            clock[0] += 45
        figures = {"samples": 10, "mean_mm": 0.1, "rms_mm": 0.1, "p95_mm": 0.2, "max_mm": 0.3}
        return {
            "arm": "UR10",
            "model": "geometry",
            "fit": {"rms_mm": 0.1},
            "test": {new_frame[0].name: {**figures, "frame": "registered"}},
        }

    monkeypatch.setattr(sessions, "run_arm_fit", fit)
    argv = ["fit", "arm-cmm", *map(str, paths), "--leave-one-out", "--out", str(tmp_path / "o")]
    assert main(argv) == 0
    said = capsys.readouterr()
    what = "calibench: fit arm-cmm --leave-one-out"
    assert said.err.splitlines() == [
        f"{what}: 1/3 folds, 45 s; about 1 min 30 s left",
        f"{what}: 2/3 folds, 1 min 30 s; about 45 s left",
        f"{what}: 3/3 folds, 2 min 15 s",
        f"{what}: done, 3 folds, 2 min 15 s",
    ]
    monkeypatch.setenv(progress.ENV, "off")
    assert main([*argv, "--force"]) == 0
    quiet = capsys.readouterr()
    assert quiet.out == said.out and "a.csv: mean 0.100" in said.out
    assert "fold" not in quiet.err


def test_every_scenario_has_its_documented_run_time():
    from calibench.scenarios.registry import instruments

    assert all(i.run_s > 0 for i in instruments())


def test_trials_on_the_study_s_own_threads_draw_nothing_into_its_bar(tmp_path, capsys, monkeypatch):
    """A study whose trials run on threads of its own process: its bar is drawn (a terminal's,
    forced) and says the trials, never a trial's own steps (the vision stage's circles)."""
    from calibench.scenarios.study.montecarlo import run_study

    monkeypatch.setenv(progress.ENV, "bar")
    monkeypatch.setattr(progress, "BAR_DELAY_S", 0.0)
    monkeypatch.setattr(progress, "DRAW_EVERY_S", 0.0)  # every report drawn
    with cf.ThreadPoolExecutor(2) as ex:
        run_study("vision-stage", 2, 0, "analytic", tmp_path, executor=ex)
    err = capsys.readouterr().err
    frames = [f.replace("\x1b[K", "") for f in err.split("\r")]
    frames = [f for f in frames if f.strip()]
    assert any("2/2 trials" in f for f in frames), err
    # neither a trial's steps (its circles, cut to the bar's 80 columns) nor its scenario run
    # counted as a step of the study's
    assert "circl" not in err and "vision-stage," not in err, err[-1500:]
    assert {int(n) for n in re.findall(r"(\d+)/2 trials", err)} <= {0, 1, 2}, err[-1500:]
    assert all(f.startswith("montecarlo vision-stage") for f in frames), frames


def _on_a_terminal(argv: list[str], cwd: Path) -> tuple[int, str, str]:
    """Run ``argv`` with stdout and stderr on a pseudo-terminal of 100 columns: its status, all
    it wrote, and the screen it leaves (carriage returns and line erasures applied)."""
    main_fd, sub_fd = pty.openpty()
    fcntl.ioctl(sub_fd, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 100, 0, 0))
    env = {k: v for k, v in os.environ.items() if k not in ("CI", progress.ENV)}
    proc = subprocess.Popen(
        argv, stdin=subprocess.DEVNULL, stdout=sub_fd, stderr=sub_fd, cwd=cwd, env=env
    )
    os.close(sub_fd)
    raw, deadline = b"", time.monotonic() + 300  # a hung command fails the test, not the suite
    while True:
        ready, _, _ = select.select([main_fd], [], [], max(0.0, deadline - time.monotonic()))
        if not ready:
            proc.kill()
            pytest.fail(f"{' '.join(argv)} still running after 300 s:\n{raw.decode()}")
        try:
            got = os.read(main_fd, 65536)
        except OSError:  # the terminal's other end closed
            break
        if not got:
            break
        raw += got
    os.close(main_fd)
    text = raw.decode(errors="replace").replace("\r\n", "\n")
    lines: list[list[str]] = [[]]
    col, i = 0, 0
    while i < len(text):
        if text.startswith("\x1b[K", i):
            del lines[-1][col:]
            i += 3
            continue
        c = text[i]
        if c == "\r":
            col = 0
        elif c == "\n":
            lines.append([])
            col = 0
        else:
            if col < len(lines[-1]):
                lines[-1][col] = c
            else:
                lines[-1].append(c)
            col += 1
        i += 1
    return proc.wait(), text, "\n".join("".join(x) for x in lines)


def test_a_study_on_a_terminal_draws_one_bar_and_says_its_end_once(tmp_path):
    """`montecarlo vision-stage` with 2 workers on a terminal: every frame drawn is the study's
    bar (no worker's circles, no second bar), the screen it leaves holds no bar, and the
    summary's line once."""
    cli = [sys.executable, "-m", "calibench.scenarios.cli", "montecarlo", "vision-stage"]
    rc, raw, screen = _on_a_terminal(
        [*cli, "--trials", "2", "--workers", "2", "--fidelity", "analytic", "--out", "s"],
        tmp_path,
    )
    assert rc == 0, raw
    # what is drawn over one line (between carriage returns, no newline) is a bar's frame
    frames = [f.replace("\x1b[K", "") for f in raw.split("\r") if "\n" not in f]
    frames = [f for f in frames if f.strip()]
    # the study's bar was drawn (its last frame may be erased before it is redrawn at 2/2)
    assert any("/2 trials" in f for f in frames), raw
    assert all(f.startswith("montecarlo vision-stage") for f in frames), frames  # it alone
    assert "circles" not in raw and "%|" not in raw, raw  # no worker's bar, no tqdm's
    assert screen.count("vision-stage: 2 trials") == 1, screen
    assert "montecarlo vision-stage" not in screen, screen  # the bar is gone at the end


def test_run_says_its_measured_time_first_and_run_all_counts_its_scenarios(clock, capsys):
    """`run all`: its scenarios are its steps (weighed by their measured times), the time left
    said from those times before the first ends; an analytic stage has no measured time."""
    from calibench.scenarios.cli.parser import build_parser
    from calibench.scenarios.registry import Scenario, instrument, instruments

    def command(*argv):
        return progress.for_command(build_parser().parse_args(["run", *argv]))

    assert command("stewart").estimate_s == instrument("stewart").run_s
    assert command("belt-stage", "--fidelity", "analytic").estimate_s is None
    total = sum(i.run_s for i in instruments())

    def belt_stage(*args):  # a scenario's run (Scenario.execute's): 10 s of the test's clock
        clock[0] += 10
        p.tick()
        return "report"

    with command("all") as p:
        assert Scenario("belt-stage", object, belt_stage).execute(None, 0, "render", None, 0)
        clock[0] += 20
        Scenario("vision-stage", object, lambda *a: "report").execute(None, 0, "render", None, 0)
    assert p.n == len(instruments()) and p.done == 2
    lines = capsys.readouterr().err.splitlines()
    assert lines[0] == (
        f"calibench: run all: 0/5 scenarios, belt-stage, 10 s; about {total - 10:.0f} s left"
    )
    assert lines[-1] == "calibench: run all: done, 2 scenarios, 30 s"
