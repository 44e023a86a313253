"""How a command takes its output folder and gives it back (:mod:`folders`: whose a folder is).

A command claims its folder before writing any output (:func:`claim`) and releases it whatever its
end (:func:`release`). One command writes in a folder at a time (:data:`LOCK`). The claim writes the
folder's :data:`~calibench.scenarios.cli.folders.MARK` at once (the former mark set aside by a
rename, the new one written whole), so an interrupted first run's folder is still known as
calibench's. ``--force`` does not delete the results it replaces: it sets them aside in
:data:`CLAIM` (the same command again keeps a second name of each there, a hard link, as it
replaces them one by one), and the release discards them only if the command wrote results of
its own, whole (every output is written whole, :mod:`calibench.writing`; a result that cannot be
told from a torn one counts as none and is removed); a command that wrote none (refused as bad
input, interrupted, crashed, stopped by a full disk) leaves the folder's results and mark as it
found them; one that replaced results (a second ``fit`` in its folder, or forced) says so in one
line at its release.
A claim left by a command killed outright, and its writes' temporary files, are settled by the
next command in that folder, as its release would have. A folder outside ``calibench-out`` that no
command marked, holding files by an output's name (a paper's ``x_axis_error_mm.csv``, a user's
own report.json or error.log), is a user's: refused, ``--force`` or not, unless its main file's
content is a result of calibench's (a folder written before the mark). A link at an output's name
is replaced by the output, never followed; the lock and the mark are never opened through one.
"""

from __future__ import annotations

import dataclasses
import errno
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
from calibench.scenarios.cli.folders import (
    CLAIM,
    LOCK,
    LOGS,
    MAIN_FILE,
    MARK,
    OUTPUTS,
    is_calibench_log,
    is_file,
    made_before_the_mark,
    marked,
    owner,
    said,
)
from calibench.scenarios.study.journal import STUDY_LOCK, study_running
from calibench.writing import is_temporary, write_text

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
        had_lock = os.path.lexists(folder / LOCK)
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
            state["say"] = force or command not in ("montecarlo", "uncertainty")
            write_text(folder / CLAIM / "claim.json", json.dumps(state))
            for name in _replaceable(folder):
                if force:
                    (folder / name).rename(folder / CLAIM / name)
                else:  # left in place, and a second name kept: put back if no result is written
                    _second_name(folder / name, folder / CLAIM / name)
            if mark is not None:  # set aside whole (rewritten, a full disk could leave it empty)
                (folder / MARK).rename(folder / CLAIM / MARK)
            mine = {"command": command, "scenario": scenario}
            write_text(folder / MARK, json.dumps(mine) + "\n")
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
                    (one.folder / STUDY_LOCK).unlink(missing_ok=True)
            finally:
                one.lock.close()
                held.pop()


def _check(folder: Path, command: str, scenario: str | None, force: bool) -> None:
    """BadInput unless the command may write in ``folder``."""
    # calibench.writing replaces a link at an output's name, never follows it; the claim's own
    # folder would be followed
    links = [name for name in (CLAIM,) if os.path.islink(folder / name)]
    if links:
        raise BadInput(
            f"--out {folder}: {links[0]} is a symbolic link; calibench neither writes through a "
            "link nor replaces one: remove it or give another --out"
        )
    held = owner(folder)
    home = Path("calibench-out").absolute().resolve()
    outside = home != folder.resolve() and home not in folder.resolve().parents
    if outside and marked(folder) is None and not made_before_the_mark(folder):
        # what is calibench's is known from the folder's mark, never from a file's name alone
        strays = [name for name in OUTPUTS if name not in LOGS and is_file(folder / name)]
        strays += [n for n in LOGS if is_file(folder / n) and not is_calibench_log(folder / n)]
        if strays:
            named = [said(MAIN_FILE[n], None) for n in strays if n in MAIN_FILE]
            what = f"the results of {named[0]} by name only" if named else "files named"
            raise BadInput(
                f"--out {folder} holds {what} ({', '.join(strays[:3])}), as calibench's outputs "
                f"are, but written by no calibench command (there is no {MARK}): give another "
                "--out, or remove them if they are calibench's (--force replaces only what "
                "calibench wrote)"
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
    for left in os.listdir(folder):  # a write cut off by a kill: never a result
        if is_temporary(left) and (folder / left).is_dir() and not (folder / left).is_symlink():
            shutil.rmtree(folder / left, ignore_errors=True)
        elif is_temporary(left):
            (folder / left).unlink(missing_ok=True)
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
    now = _results(folder)
    # a result counts only whole: one that cannot be told from a torn one is none
    written = any(found.get(name) != st and _whole(folder / name) for name, st in now.items())
    replaced = _replaced(found, mark) if written and found and info.get("say", True) else None
    if not written:
        # no results written: what the command did write (a study's description, an empty
        # journal, a torn result) goes, and what it found comes back; a crash's traceback stays
        for name in OUTPUTS:
            torn = name in now and found.get(name) != now[name]
            if (name not in present or torn) and name not in LOGS and is_file(folder / name):
                (folder / name).unlink()
        aside = is_file(state / MARK)  # the former mark, set aside whole (a claim of before: text)
        for path in state.iterdir():
            kept = path.name in LOGS and is_file(folder / path.name)
            if path.name != "claim.json" and not kept:
                path.rename(folder / path.name)
        if mark is None:
            (folder / MARK).unlink(missing_ok=True)
        elif not aside:
            write_text(folder / MARK, mark)
    shutil.rmtree(state, ignore_errors=True)
    return replaced


def _replaceable(folder: Path) -> list[str]:
    """The outputs of calibench's in ``folder`` that --force sets aside (a user's error.log is
    theirs: kept in place)."""
    return [
        name
        for name in OUTPUTS
        if name != MARK
        and is_file(folder / name)
        and (name not in LOGS or is_calibench_log(folder / name))
    ]


def _second_name(path: Path, aside: Path) -> None:
    """A hard link of ``path`` at ``aside``: each output is replaced by a rename (a new file), so
    the former stays whole under its second name. A file system without hard links keeps none."""
    try:
        os.link(path, aside, follow_symlinks=False)
    except OSError:
        pass


def _whole(path: Path) -> bool:
    """Whether a result file is whole: a JSON one parses (every output is written whole,
    calibench.writing; this tells a torn one left by any other writer)."""
    if path.suffix != ".json":
        return True
    try:
        json.loads(path.read_bytes())
    except (OSError, ValueError):
        return False
    return True


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
        try:  # a link planted at the lock's name is not followed out of the folder
            how = os.O_WRONLY | os.O_CREAT | os.O_APPEND | os.O_NOFOLLOW
            fd = os.open(folder / LOCK, how, 0o644)
        except OSError as e:
            if e.errno != errno.ELOOP:
                raise
            raise BadInput(
                f"--out {folder}: {LOCK} is a symbolic link; calibench neither writes through a "
                "link nor replaces one: remove it or give another --out"
            ) from None
        f = os.fdopen(fd, "a")
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
