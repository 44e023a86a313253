"""A study stopped by the signals a machine sends (issue 37): SIGTERM (timeout, systemd, docker)
is handled as Ctrl-C, one line and the journal kept; a parent killed outright (SIGKILL) leaves
no worker behind; and the rerun's results equal an uninterrupted run's, trial by trial."""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

STUDY = ["montecarlo", "belt-stage", "--trials", "40", "--workers", "2", "--seed", "3"]
PROGRESS = "calibench: montecarlo belt-stage: "  # its lines off a terminal


def _start(out: Path) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-m", "calibench.scenarios.cli", *STUDY, "--out", str(out)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        env={**os.environ, "MUJOCO_GL": "egl"},
        start_new_session=True,  # the signal goes to the parent alone, as `timeout` sends it
        text=True,
    )


def _children(pid: int) -> set[int]:
    out = set()
    for task in Path(f"/proc/{pid}/task").glob("*"):
        try:
            out |= {int(c) for c in (task / "children").read_text().split()}
        except OSError:
            pass
    return out


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().split(")")[-1].split()[0]
    except OSError:
        return False
    return state != "Z"


def _rows(out: Path) -> int:
    journal = out / "trials.jsonl"
    return journal.read_text().count("\n") if journal.exists() else 0


def _stop(out: Path, sig: int, after_rows: int) -> tuple[int, str, set[int]]:
    """Start the study, wait for ``after_rows`` finished trials (0: for its workers to start),
    send ``sig`` to the parent alone; its exit status, stderr and its workers' pids."""
    proc = _start(out)
    workers: set[int] = set()
    deadline = time.time() + 120
    try:
        while time.time() < deadline and proc.poll() is None:
            workers |= _children(proc.pid)
            if len(workers) >= 2 and _rows(out) >= after_rows:
                break
            time.sleep(0.05)
        proc.send_signal(sig)
        _, err = proc.communicate(timeout=60)
    finally:  # never leave a study running behind the tests
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    return proc.returncode, err, workers


def _gone(pids: set[int], seconds: float = 10.0) -> bool:
    deadline = time.time() + seconds
    while time.time() < deadline:
        if not any(_alive(p) for p in pids):
            return True
        time.sleep(0.1)
    return False


def _estimates(out: Path) -> dict[int, dict]:
    rows = [json.loads(x) for x in (out / "trials.jsonl").read_text().splitlines() if x.strip()]
    return {r["trial"]: {k: v for k, v in r.items() if k != "elapsed_s"} for r in rows}


def test_sigterm_and_sigkill_leave_no_worker_and_lose_no_trial(tmp_path):
    whole = tmp_path / "whole"
    done = subprocess.run(
        [sys.executable, "-m", "calibench.scenarios.cli", *STUDY, "--out", str(whole)],
        capture_output=True,
        env={**os.environ, "MUJOCO_GL": "egl"},
    )
    assert done.returncode == 0, done.stderr
    out = tmp_path / "stopped"
    # SIGTERM while the workers start, SIGTERM with trials finished, then SIGKILL
    for sig, after in ((signal.SIGTERM, 0), (signal.SIGTERM, 5), (signal.SIGKILL, 10)):
        rc, err, workers = _stop(out, sig, after)
        assert workers, "the study's workers were seen"
        assert _gone(workers), f"workers left behind after {sig.name}"
        if sig == signal.SIGTERM:
            assert rc == 130, err
            assert err.strip().splitlines()[-1].startswith("calibench: interrupted"), err
            # one line besides the study's progress (a line every 30 s; no final one)
            said = [x for x in err.strip().splitlines() if not x.startswith(PROGRESS)]
            assert len(said) == 1 and ": done," not in err, err
        else:
            assert rc == -signal.SIGKILL
    resumed = subprocess.run(
        [sys.executable, "-m", "calibench.scenarios.cli", *STUDY, "--out", str(out)],
        capture_output=True,
        env={**os.environ, "MUJOCO_GL": "egl"},
    )
    assert resumed.returncode == 0, resumed.stderr
    assert _estimates(out) == _estimates(whole)
