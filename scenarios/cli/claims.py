"""How a command takes its output folder and gives it back (:mod:`folders`: whose a folder is).

A command claims its folder before writing any output (:func:`claim`) and releases it whatever its
end (:func:`release`). One command writes in a folder at a time (:data:`LOCK`). The claim writes the
folder's :data:`~calibench.scenarios.cli.folders.MARK` at once, so an interrupted first run's folder
is still known as calibench's. ``--force`` does not delete the results it replaces: it sets them
aside in :data:`CLAIM`, and the release discards them only if the command wrote results of its own;
a command that wrote none (refused as bad input, interrupted, crashed) leaves the folder's results
and mark as it found them; one that replaced results (a second ``fit`` in its folder, or forced)
says so in one line at its release. A claim left by a command killed outright is settled by the next
command in that folder, as its release would have. A folder outside ``calibench-out`` that no
command marked, holding files by an output's name (a paper's ``x_axis_error_mm.csv``), is a
user's: refused, ``--force`` or not.
"""

from __future__ import annotations

import dataclasses
import fcntl
import json
import os
import shutil
import signal
import sys
import threading
import time
from pathlib import Path
from typing import IO

from calibench.errors import BadInput
from calibench.scenarios.cli.folders import MAIN_FILE, MARK, OUTPUTS, is_file, owner, said
from calibench.scenarios.study.journal import study_running

LOCK = ".calibench.lock"  # held (flock) by the command writing in the folder
# while a command writes: what it found (claim.json: the mark, the results' stats) and the results
# --force set aside
CLAIM = ".calibench-claim"
# the files whose writing makes a command's results: its main file, and a study's summary (a
# figure or a recording written before them is a part, a study's description or empty journal none)
RESULTS = (*(name for name in MAIN_FILE if name != "study.json"), "summary.json")


@dataclasses.dataclass
class Claim:
    """A command's hold on its folder: the folder (absolute) and its lock, open."""

    folder: Path
    lock: IO[str]


def claim(folder: Path, command: str, scenario: str | None, force: bool, held: list[Claim]) -> None:
    """Make ``folder`` this command's before any output is written; the claim is appended to
    ``held`` as soon as it is made (an interrupt landing just after still finds it there), and
    :func:`release` ends it.

    Parameters
    ----------
    folder : Path
        The command's --out (it exists and is writable).
    command, scenario : str
        The command writing there (``scenario`` None for camera and iso230).
    force : bool
        Replace another command's results instead of refusing.
    held : list of Claim
        The caller's claims, to release at its end.

    Raises
    ------
    BadInput
        Another command writes there; the folder holds another command's results and ``force``
        is not given, or a user's files by an output's name.
    """
    folder = folder.absolute()
    try:
        folder.mkdir(parents=True, exist_ok=True)
        had_lock = (folder / LOCK).exists()
        lock = _lock(folder)
    except OSError as e:  # run all's folder a file, a file system without locks
        raise BadInput(f"--out {folder}: cannot write there ({e.strerror})") from None
    made = False
    try:
        with _signals_deferred(reraise=True):
            _settle(folder)  # a claim left by a command killed outright: as its release would
            _check(folder, command, scenario, force)
            if force and study_running(folder):
                raise BadInput(
                    f"{folder}: a calibench study is running in this folder; --force would remove "
                    "its trials under it: wait for it, or use another --out"
                )
            mark = (folder / MARK).read_text() if is_file(folder / MARK) else None
            (folder / CLAIM).mkdir()
            present = [name for name in OUTPUTS if is_file(folder / name)]
            state: dict[str, object] = {
                "mark": mark,
                "found": _results(folder),
                "present": present,
            }
            # a study resumed extends its results rather than replacing them: nothing to say
            state["say"] = force or command != "montecarlo"
            (folder / CLAIM / "claim.json").write_text(json.dumps(state))
            for name in OUTPUTS if force else ():
                if is_file(folder / name):
                    (folder / name).rename(folder / CLAIM / name)
            mine = {"command": command, "scenario": scenario}
            (folder / MARK).write_text(json.dumps(mine) + "\n")
            held.append(Claim(folder, lock))
            made = True
    finally:
        if not made:
            _settle(folder)  # a claim cut off as it was made: undone
            if not had_lock:  # refused: the folder left as it was
                (folder / LOCK).unlink(missing_ok=True)
            lock.close()


def release(held: list[Claim], reraise: bool = False) -> None:
    """End the claims in ``held`` (emptying it), whatever the command's end: where it wrote
    results, those it replaced are gone; where not, they are put back with their mark. An
    interrupt meanwhile waits for them, and is then raised (``reraise``: ``run all``, which goes
    on to its next scenario otherwise) or dropped (the command is ending anyway)."""
    with _signals_deferred(reraise):
        while held:
            one = held[-1]
            try:
                replaced = _settle(one.folder)
                if replaced:  # never silently: a second fit in a folder replaces the first
                    print(f"calibench: {one.folder}: {replaced}", file=sys.stderr, flush=True)
                if not is_file(one.folder / MARK):  # no results of any command's: no trace left
                    (one.folder / LOCK).unlink(missing_ok=True)
            finally:
                one.lock.close()
                held.pop()


def _check(folder: Path, command: str, scenario: str | None, force: bool) -> None:
    """BadInput unless the command may write in ``folder``."""
    held = owner(folder)
    home = Path("calibench-out").absolute().resolve()
    if held is None and home != folder.resolve() and home not in folder.resolve().parents:
        # a crash's traceback is calibench's whatever folder it is in
        strays = [name for name in OUTPUTS if name != "error.log" and is_file(folder / name)]
        if strays:
            raise BadInput(
                f"--out {folder} holds {', '.join(strays[:3])}, named as calibench's outputs but "
                f"written by no calibench command (there is no {MARK}): give another --out, or "
                "remove them if they are calibench's (--force replaces only what calibench wrote)"
            )
    same = held is not None and held[0] == command and held[1] in (None, scenario)
    if held is not None and not same and not force:
        raise BadInput(
            f"--out {folder} holds the results of {said(*held)}; {said(command, scenario)} would "
            "mix its own with them: give another --out, or --force to replace them"
        )


def _settle(folder: Path) -> str | None:
    """Resolve the claim recorded in ``folder``'s :data:`CLAIM`, if any: results written since
    (a result file new or changed since the claim) keep the claim's mark; none, and what was
    found is put back.

    Returns
    -------
    str or None
        Where results written since replaced results found by the claim: what they replaced, in
        words (None for a study resumed, which extends its own).
    """
    state = folder / CLAIM
    if is_file(state):  # no claim's: in the way of the next
        state.unlink()
    if not state.is_dir():
        return None
    try:  # written whole before anything is set aside
        info = json.loads((state / "claim.json").read_text())
        found, present, mark = dict(info["found"]), list(info["present"]), info["mark"]
    except (OSError, ValueError, KeyError, TypeError):  # cut off before its record
        shutil.rmtree(state, ignore_errors=True)
        return None
    written = any(found.get(name) != stat for name, stat in _results(folder).items())
    replaced = _replaced(found, mark) if written and found and info.get("say", True) else None
    if not written:
        # no results written: what the command did write (a study's description, an empty
        # journal) goes, and what it found comes back; a crash's traceback stays
        for name in OUTPUTS:
            if name not in present and name != "error.log" and is_file(folder / name):
                (folder / name).unlink()
        for path in state.iterdir():
            kept = path.name == "error.log" and is_file(folder / path.name)
            if path.name not in ("claim.json", MARK) and not kept:
                path.rename(folder / path.name)
        if mark is None:
            (folder / MARK).unlink(missing_ok=True)
        else:
            (folder / MARK).write_text(mark)
    shutil.rmtree(state, ignore_errors=True)
    return replaced


def _replaced(found: dict[str, list[int]], mark: str | None) -> str:
    """The results a claim found, replaced since, in words: which command wrote them and when."""
    try:
        held = json.loads(mark) if mark is not None else {}
        by = f" of {said(str(held['command']), held.get('scenario'))}"
    except (ValueError, KeyError, TypeError):  # a folder made before the mark: its files say it
        by = ""
    when = time.strftime("%Y-%m-%d %H:%M", time.localtime(max(s[1] for s in found.values()) / 1e9))
    return f"replaced the former results{by} ({', '.join(sorted(found))} of {when})"


def _results(folder: Path) -> dict[str, list[int]]:
    """The results in ``folder``: each of :data:`RESULTS` that holds anything, by name: size,
    modification time, inode (a rename keeps it)."""
    out = {}
    for name in RESULTS:
        if is_file(folder / name):
            st = (folder / name).lstat()
            if st.st_size:
                out[name] = [st.st_size, st.st_mtime_ns, st.st_ino]
    return out


def _lock(folder: Path) -> IO[str]:
    """The folder's :data:`LOCK`, held; BadInput if another command holds it."""
    while True:
        f = open(folder / LOCK, "a")
        try:
            fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            f.close()
            raise BadInput(
                f"--out {folder}: another calibench command is writing in this folder; wait for "
                "it to finish (a study: then rerun to resume) or use another --out"
            ) from None
        try:  # the file locked is still the folder's (its last holder may have removed it)
            if os.fstat(f.fileno()).st_ino == (folder / LOCK).stat().st_ino:
                return f
        except FileNotFoundError:
            pass
        f.close()


class _signals_deferred:
    """Ctrl-C and SIGTERM held back for the block (Python runs signal handlers in the main
    thread whatever thread the signal reached): a claim is made or released whole. On leaving,
    a signal that came is raised as KeyboardInterrupt (``reraise``) or dropped."""

    def __init__(self, reraise: bool):
        self.reraise, self.came, self.old = reraise, False, None

    def __enter__(self):
        if threading.current_thread() is threading.main_thread():
            self.old = [signal.getsignal(s) for s in (signal.SIGINT, signal.SIGTERM)]
            for s, old in zip((signal.SIGINT, signal.SIGTERM), self.old, strict=True):
                if old is not signal.SIG_IGN:  # an ignored signal stays ignored
                    signal.signal(s, self._note)

    def _note(self, signum, frame):
        self.came = True

    def __exit__(self, *exc):
        if self.old is not None:
            for s, old in zip((signal.SIGINT, signal.SIGTERM), self.old, strict=True):
                signal.signal(s, old)
        if self.came and self.reraise and exc[0] is None:
            raise KeyboardInterrupt
