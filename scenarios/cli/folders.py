"""Whose results an output folder holds.

Each command writes to a folder of its own (``calibench-out/<scenario>`` for ``run``,
``<scenario>-fit``, ``<scenario>-discover``, ``<scenario>-montecarlo``, ``camera``, ``iso230``):
simulated and real results never share one. A folder says who writes it in :data:`MARK`, written
when the command claims it, before any output (so an interrupted first run's folder is still known
as calibench's); one that holds another command's results (or, made before the mark, another
command's main file) is refused unless ``--force`` says to replace them, and then only calibench's
own outputs are replaced, never a user's other files, and only once the command has written its
own: one that ends having written nothing (bad input, an interruption, a crash) leaves the folder
as it found it. One command writes in a folder at a time (:data:`LOCK`). A folder no command
marked that holds files by an output's name (a paper's ``x_axis_error_mm.csv``) is a user's:
refused, ``--force`` or not (outside ``calibench-out``, which is calibench's own).
"""

from __future__ import annotations

import contextlib
import fcntl
import json
import os
import shutil
import signal
import threading
from pathlib import Path

from calibench.errors import BadInput
from calibench.scenarios.study.journal import study_running

MARK = ".calibench.json"
LOCK = ".calibench.lock"  # held (flock) by the command writing in the folder
# while a command writes: what it found (claim.json: the mark, the outputs' stats) and the results
# --force set aside, kept until the command has written its own
CLAIM = ".calibench-claim"
# outputs that say nothing was written: the mark, and a crash's traceback
NOT_RESULTS = (MARK, "error.log")
_HELD: dict[Path, object] = {}  # this process's claims: each folder's lock, open

# each command's main output: who wrote a folder made before MARK existed
MAIN_FILE = {
    "report.json": "run",
    "fit.json": "fit",
    "discovery.json": "discover",
    "study.json": "montecarlo",
    "trials.jsonl": "montecarlo",
    "intrinsics.json": "camera",
    "iso230.json": "iso230",
}

# what --force removes: every file a command of calibench's writes, by name
OUTPUTS = (
    *MAIN_FILE,
    MARK,
    "summary.json",
    "trials.parquet",
    "study.png",
    "study.rrd",
    "run.rrd",
    "error.log",
    "fit.png",
    "residuals.csv",
    "discovery.png",
    "camera.png",
    "iso230.png",
    "figure.png",
    "arm_cmm.png",  # the runs' figures' names before figure.png
    "error_map.png",
    "probe_scanner.png",
    "stewart.png",
    "vision_stage.png",
    "x_axis_error_mm.csv",
    "y_axis_error_mm.csv",
)


def default_out(command: str, scenario: str | None) -> Path:
    """The command's own folder under ./calibench-out."""
    if scenario is None:
        return Path("calibench-out") / command
    if command == "run":
        return Path("calibench-out") / scenario
    return Path("calibench-out") / f"{scenario}-{command}"


def owner(folder: Path) -> tuple[str, str | None] | None:
    """(command, scenario) whose results ``folder`` holds, or None for a folder of none."""
    try:
        mark = json.loads((folder / MARK).read_text())
        return str(mark["command"]), mark.get("scenario")
    except FileNotFoundError:
        pass
    except (OSError, ValueError, KeyError, TypeError):
        raise BadInput(
            f"{folder / MARK} does not say which command wrote {folder} (corrupt?): remove it or "
            "use another --out"
        ) from None
    found = next((cmd for name, cmd in MAIN_FILE.items() if (folder / name).is_file()), None)
    return None if found is None else (found, None)


def _said(command: str, scenario: str | None) -> str:
    return f"`calibench {command}{'' if scenario is None else ' ' + scenario}`"


def claim(folder: Path, command: str, scenario: str | None, force: bool) -> None:
    """Make ``folder`` this command's, before any output is written; :func:`release` ends the claim.

    Refused if another command is writing there, if it holds another command's results (unless
    ``force``, which sets them aside in :data:`CLAIM`, calibench's outputs only), or if no command
    marked it but it holds files by an output's name (a user's own; not in ``calibench-out``).
    Then :data:`MARK` says whose results it takes.

    Parameters
    ----------
    folder : Path
        The command's --out (it exists and is writable).
    command, scenario : str
        The command writing there (``scenario`` None for camera and iso230).
    force : bool
        Replace another command's results instead of refusing.

    Raises
    ------
    BadInput
        Another command writes there; the folder holds another command's results and ``force``
        is not given, or a user's files by an output's name.
    """
    folder.mkdir(parents=True, exist_ok=True)
    had_lock = (folder / LOCK).exists()
    lock = _lock(folder)
    try:
        with _signals_held():
            _settle(folder)  # a claim left by a command killed outright: as its release would
            replace = _check(folder, command, scenario, force)
            if replace and study_running(folder):
                raise BadInput(
                    f"{folder}: a calibench study is running in this folder; --force would remove "
                    "its trials under it: wait for it, or use another --out"
                )
            found = {} if replace else _stats(folder)
            mark = (folder / MARK).read_text() if _is_file(folder / MARK) else None
            (folder / CLAIM).mkdir()
            (folder / CLAIM / "claim.json").write_text(json.dumps({"mark": mark, "found": found}))
            for name in OUTPUTS if replace else ():
                if _is_file(folder / name):
                    (folder / name).rename(folder / CLAIM / name)
            mine = {"command": command, "scenario": scenario}
            (folder / MARK).write_text(json.dumps(mine) + "\n")
            _HELD[folder] = lock
    except BaseException:
        if _HELD.get(folder) is not lock:
            if not had_lock:  # refused: the folder left as it was
                (folder / LOCK).unlink(missing_ok=True)
            lock.close()
        raise


def _check(folder: Path, command: str, scenario: str | None, force: bool) -> bool:
    """Whether the command may write in ``folder`` (BadInput if not), and whether the results
    there are to be replaced."""
    held = owner(folder)
    if held is None and folder.parts[:1] != ("calibench-out",):
        strays = [name for name in OUTPUTS if _is_file(folder / name)]
        if strays:
            raise BadInput(
                f"--out {folder} holds {', '.join(strays[:3])}, named as calibench's outputs but "
                f"written by no calibench command (there is no {MARK}): give another --out, or "
                "remove them if they are calibench's (--force replaces only what calibench wrote)"
            )
    same = held is not None and held[0] == command and held[1] in (None, scenario)
    if held is not None and not same and not force:
        raise BadInput(
            f"--out {folder} holds the results of {_said(*held)}; {_said(command, scenario)} would "
            "mix its own with them: give another --out, or --force to replace them"
        )
    return force


def release(folder: Path) -> None:
    """End this process's claim on ``folder`` (nothing if it holds none), whatever the command's
    end: if it wrote results, those it replaced are gone; if not, they are put back with their
    mark (a command refused as bad input leaves the folder as it found it)."""
    lock = _HELD.pop(folder, None)
    if lock is None:
        return
    try:
        with _signals_held():
            _settle(folder)
            if not _is_file(folder / MARK):  # no results of any command's: no trace left
                (folder / LOCK).unlink(missing_ok=True)
    finally:
        lock.close()


def _settle(folder: Path) -> None:
    """Resolve the claim recorded in ``folder``'s :data:`CLAIM`, if any."""
    state = folder / CLAIM
    try:
        info = json.loads((state / "claim.json").read_text())
    except FileNotFoundError:
        return
    except (OSError, ValueError):  # a claim cut off as it was made: nothing was set aside yet
        shutil.rmtree(state, ignore_errors=True)
        return
    found = info["found"]
    wrote = any(found.get(k) != v for k, v in _stats(folder).items())
    if not wrote:
        if info["mark"] is None:
            (folder / MARK).unlink(missing_ok=True)
        else:
            (folder / MARK).write_text(info["mark"])
        for path in state.iterdir():
            if path.name not in ("claim.json", MARK) and not _is_file(folder / path.name):
                path.rename(folder / path.name)
    shutil.rmtree(state, ignore_errors=True)


def _stats(folder: Path) -> dict[str, list[int]]:
    """The results in ``folder`` (outputs but :data:`NOT_RESULTS`): name -> size, mtime, inode."""
    out = {}
    for name in OUTPUTS:
        if name not in NOT_RESULTS and _is_file(folder / name):
            st = (folder / name).lstat()
            out[name] = [st.st_size, st.st_mtime_ns, st.st_ino]
    return out


def _lock(folder: Path):
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
        try:  # the file locked is still the folder's (its holder may have removed it meanwhile)
            if os.fstat(f.fileno()).st_ino == (folder / LOCK).stat().st_ino:
                return f
        except FileNotFoundError:
            pass
        f.close()


@contextlib.contextmanager
def _signals_held():
    """Ctrl-C and SIGTERM held back for the block (delivered after it): a claim is made or
    released whole."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT, signal.SIGTERM})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


def _is_file(path: Path) -> bool:
    return path.is_file() or path.is_symlink()


def writable_folder(out: Path | None, option: str = "--out") -> Path | None:
    """``out`` must be a folder calibench can write: said before any work, in one line naming
    ``option``. Makes it; returns it if this call created it (a command ending in bad input
    removes it again, empty), else None."""
    if out is None:
        return None
    out = Path(out)
    try:
        for parent in [out, *out.parents]:
            if parent.exists() and not parent.is_dir():
                raise BadInput(f"{option} {out}: {parent} is a file, not a folder")
        created = None if out.exists() else out
    except OSError as e:  # a name too long for the file system, a folder that cannot be read
        raise BadInput(
            f"{option} {str(out)[:80]}{'...' if len(str(out)) > 80 else ''}: cannot write there "
            f"({e.strerror})"
        ) from None
    try:
        out.mkdir(parents=True, exist_ok=True)
        probe = out / ".calibench-write-test"
        probe.touch()
        probe.unlink()
    except OSError as e:
        raise BadInput(f"{option} {out}: cannot write there ({e.strerror})") from None
    return created
