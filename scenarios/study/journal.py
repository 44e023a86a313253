"""A study's folder as a resumable record: the journal of finished trials (one JSON line each,
appended as they finish, so nothing is lost on interruption and a rerun skips them) and
study.json, which says which study the folder holds (one study per folder)."""

from __future__ import annotations

import contextlib
import errno
import fcntl
import json
import os
from pathlib import Path
from typing import TextIO

from calibench.errors import BadInput
from calibench.writing import write_text

JOURNAL = "trials.jsonl"
STUDY_LOCK = ".study.lock"  # held (flock) by the study running in the folder
ROW_START = '{"trial": '  # how every row of the journal begins


def load_journal(out_dir: Path) -> dict[int, dict]:
    """Finished trials by index. A row an interruption tore is ignored; anything else that is not
    a trial of calibench's is bad input, said with the line.

    Parameters
    ----------
    out_dir : Path
        The study's folder.

    Returns
    -------
    dict of int to dict
        The journal's rows (:func:`~calibench.scenarios.study.trials.run_trial`) by trial index;
        empty when there is no journal yet.

    Raises
    ------
    BadInput
        The journal cannot be read, or holds a line that is not a trial of calibench's.
    """
    path = out_dir / JOURNAL
    done: dict[int, dict] = {}
    if not path.exists():
        return done
    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError):
        raise BadInput(
            f"{path} cannot be read as a journal of trials: remove it or use another --out"
        ) from None
    lines = text.splitlines()
    for k, line in enumerate(lines):
        if not line.strip():
            continue
        try:
            row = json.loads(line)
        except json.JSONDecodeError:
            last = k == len(lines) - 1 and not text.endswith("\n")
            if last or line.startswith(ROW_START) or ROW_START.startswith(line):
                # a row torn by an interruption, however early (a resume starts a fresh line
                # after it): what a crash leaves, dropped, the finished trials kept
                continue
            row = None
        if not (
            isinstance(row, dict)
            and isinstance(row.get("trial"), int)
            and row["trial"] >= 0
            and isinstance(row.get("ok"), bool)
            and "seed" in row
        ):
            raise BadInput(
                f"{path} line {k + 1} is not a finished trial of calibench's: the journal is "
                "corrupt or another program's; remove it or use another --out"
            )
        done[row["trial"]] = row
    return done


def row_keys(rows: list[dict]) -> set[str]:
    """Every key any of ``rows`` holds: a thousand trials' rows hold a hundred each, so one set
    union in C, not a loop per row."""
    return set().union(*rows)


def open_journal(out_dir: Path) -> TextIO:
    """The journal, opened to append finished trials to; a last line that an interruption tore is
    closed first, so the next row starts on a line of its own.

    Parameters
    ----------
    out_dir : Path
        The study's folder (it exists).

    Returns
    -------
    TextIO
        The journal in append mode; the caller closes it (a ``with`` block).
    """
    path = out_dir / JOURNAL
    torn = path.exists() and path.stat().st_size and not path.read_bytes().endswith(b"\n")
    journal = _appended(path)  # the caller's with block closes it
    if torn:  # an interruption cut the last line: start a fresh one
        journal.write("\n")
    return journal


def record_study(out_dir: Path, meta: dict) -> None:
    """Write study.json, which says the study a folder holds; a folder that holds another study
    (or a study.json that is not one) is refused, so a resumed study cannot mix two.

    Parameters
    ----------
    out_dir : Path
        The study's folder (it exists).
    meta : dict
        The study: ``scenario``, ``seed``, ``fidelity``, and ``arm`` and ``config`` where given.

    Raises
    ------
    BadInput
        The folder holds a different study, or a study.json that cannot be read.
    """
    meta_path = out_dir / "study.json"
    old = None
    if meta_path.exists():
        try:
            old = json.loads(meta_path.read_text())
        except (OSError, UnicodeDecodeError, json.JSONDecodeError):
            raise BadInput(
                f"{meta_path} is not a study's description (corrupt?): remove it or use another "
                "--out"
            ) from None
    if old is not None and old != meta:
        raise BadInput(
            f"{out_dir} holds a different study ({meta_path.read_text().strip()}); use another "
            "--out, or --force to replace it"
        )
    write_text(meta_path, json.dumps(meta) + "\n")
    from calibench.scenarios.cli.folders import MARK, marked  # the command line's, which needs this

    if marked(out_dir) is None:  # a study started from Python: its folder known as calibench's
        mine = {"command": "montecarlo", "scenario": meta["scenario"]}
        write_text(out_dir / MARK, json.dumps(mine) + "\n")


def _appended(path: Path) -> TextIO:
    """``path`` opened to append, never through a symbolic link (refused in one line)."""
    try:
        fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_APPEND | os.O_NOFOLLOW, 0o644)
    except OSError as e:
        if e.errno != errno.ELOOP:
            raise
        raise BadInput(
            f"{path} is a symbolic link: calibench neither writes through a link nor replaces "
            "one; remove it or give another --out"
        ) from None
    return os.fdopen(fd, "a")


def study_running(out_dir: Path) -> bool:
    """Whether a study holds ``out_dir``'s lock now (:func:`study_lock`)."""
    lock = out_dir / STUDY_LOCK
    if not lock.is_file() or lock.is_symlink():
        return False
    with _appended(lock) as f:
        try:
            fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            return True
    return False


@contextlib.contextmanager
def study_lock(out_dir: Path):
    """Hold the folder's study lock for the block: a second study started into the same folder
    (the same command twice, say) is refused instead of doing all the work again beside the
    first. The lock is the operating system's (``flock``): a killed study leaves none behind."""
    out_dir.mkdir(parents=True, exist_ok=True)
    f = _appended(out_dir / STUDY_LOCK)
    try:
        try:
            fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise BadInput(
                f"{out_dir}: another calibench study is running in this folder; wait for it to "
                "finish (then rerun to resume) or use another --out"
            ) from None
        yield
    finally:
        f.close()
