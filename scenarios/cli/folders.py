"""Whose results an output folder holds.

Each command writes to a folder of its own (``calibench-out/<scenario>`` for ``run``,
``<scenario>-fit``, ``<scenario>-discover``, ``<scenario>-montecarlo``, ``camera``, ``iso230``):
simulated and real results never share one. A folder says who writes it in :data:`MARK`; one that
holds another command's results (or, made before the mark, another command's main file) is
refused unless ``--force`` says to replace them, and then only calibench's own outputs are
replaced, never a user's other files (``claims``: how a command takes a folder and gives it back).
"""

from __future__ import annotations

import errno
import json
import os
import re
import stat
import tempfile
from pathlib import Path

from calibench.errors import BadInput

MARK = ".calibench.json"
LOCK = ".calibench.lock"  # held (flock) by the command writing in the folder
# while a command writes: what it found (claim.json: the mark, the results' stats) and the results
# --force set aside
CLAIM = ".calibench-claim"
LOG_HEADER = "calibench: internal error"  # the first line of the error.log calibench writes
_NAME = re.compile(r"[a-z0-9][a-z0-9-]{0,39}")  # a command's or a scenario's name in a mark

# each command's main output: who wrote a folder made before MARK existed
MAIN_FILE = {
    "report.json": "run",
    "fit.json": "fit",
    "discovery.json": "discover",
    "study.json": "montecarlo",
    "trials.jsonl": "montecarlo",
    "intrinsics.json": "camera",
    "iso230.json": "iso230",
    "acceptance.json": "acceptance",
    "uncertainty.json": "uncertainty",
    "uncertainty_trials.jsonl": "uncertainty",
}

# a crash's traceback: error.log, or beside a user's own error.log the second name
LOGS = ("error.log", "calibench-error.log")

# what --force removes: every file a command of calibench's writes, by name
OUTPUTS = (
    *MAIN_FILE,
    MARK,
    "summary.json",
    "trials.parquet",
    "study.png",
    "study.rrd",
    "run.rrd",
    "recording.csv",  # a run's simulated recording and what it conceals: parts of its results
    "recording.truth.json",
    *LOGS,
    "fit.png",
    "residuals.csv",
    "discovery.png",
    "camera.png",
    "iso230.png",
    "uncertainty.png",
    "uncertainty.rrd",
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
    held = marked(folder)
    if held is not None:
        return held
    found = next((cmd for name, cmd in MAIN_FILE.items() if (folder / name).is_file()), None)
    return None if found is None else (found, None)


def marked(folder: Path) -> tuple[str, str | None] | None:
    """(command, scenario) that ``folder``'s :data:`MARK` names, or None where it has none.

    Raises
    ------
    BadInput
        The mark is not a plain file (a link, a folder, a pipe), or does not name a command as
        calibench writes it (corrupt, or not calibench's).
    """
    path = folder / MARK
    try:  # never through a link, never blocked on a pipe planted at the name
        fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK)
    except FileNotFoundError:
        return None
    except OSError as e:
        why = "a symbolic link" if e.errno == errno.ELOOP else e.strerror
        raise _bad_mark(folder, why) from None
    if not stat.S_ISREG(os.fstat(fd).st_mode):  # a folder, a pipe
        os.close(fd)
        raise _bad_mark(folder, "not a file")
    with os.fdopen(fd, "rb") as f:
        text = f.read(4096)
    try:
        mark = json.loads(text)
        command, scenario = mark["command"], mark.get("scenario")
    except (ValueError, KeyError, TypeError, AttributeError):
        raise _bad_mark(folder, "corrupt?") from None
    if not (isinstance(command, str) and _NAME.fullmatch(command)) or not (
        scenario is None or (isinstance(scenario, str) and _NAME.fullmatch(scenario))
    ):
        raise _bad_mark(folder, "corrupt?")
    return command, scenario


def _bad_mark(folder: Path, why: str | None) -> BadInput:
    return BadInput(
        f"{folder / MARK} does not say which command wrote {folder} ({why}): remove it or use "
        "another --out"
    )


# the keys each main file of calibench's holds: a folder made before the mark is known as
# calibench's by its main file's content, never by a name alone (a user's own report.json)
_KEYS = {
    "report.json": {"scenario", "parameters", "checks", "ok"},
    "fit.json": {"scenario", "model"},
    "discovery.json": {"scenario", "samples", "effects"},
    "study.json": {"scenario", "seed", "fidelity"},
    "intrinsics.json": {"image_size", "K", "dist", "used", "rejected"},
    "iso230.json": {"axis", "per_target"},
    "acceptance.json": {"scenario", "test", "before", "after"},
    "uncertainty.json": {"scenario", "task", "grid", "trials"},
    "uncertainty_trials.jsonl": {"study", "batch", "trial", "values"},  # its first row
    "trials.jsonl": {"trial"},  # its first row
}


def made_before_the_mark(folder: Path) -> bool:
    """Whether ``folder`` (without :data:`MARK`) holds a main file whose content is calibench's:
    a folder some command wrote before the mark existed."""
    for name, keys in _KEYS.items():
        try:
            if (folder / name).is_symlink() or (folder / name).stat().st_size > 2**24:
                continue  # a link is nobody's result; a result is not that large
            text = (folder / name).read_bytes()
            held = json.loads(text.split(b"\n", 1)[0] if name.endswith(".jsonl") else text)
        except (OSError, ValueError):
            continue
        if isinstance(held, dict) and keys <= held.keys():
            return True
    return False


def is_calibench_log(path: Path) -> bool:
    """Whether ``path`` is a traceback calibench wrote (its first line :data:`LOG_HEADER`'s, or,
    before the header, a Python traceback through calibench's code): never known by its name
    alone, a user's own error.log is theirs."""
    try:
        fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW | os.O_NONBLOCK)
    except OSError:
        return False
    if not stat.S_ISREG(os.fstat(fd).st_mode):
        os.close(fd)
        return False
    with os.fdopen(fd, "rb") as f:
        head = f.read(65536).decode("utf-8", "replace")
    old = head.startswith("Traceback (most recent call last):") and "calibench" in head
    return head.startswith(LOG_HEADER) or old


def said(command: str, scenario: str | None) -> str:
    """The command as a message quotes it: `calibench fit belt-stage`."""
    return f"`calibench {command}{'' if scenario is None else ' ' + scenario}`"


def is_file(path: Path) -> bool:
    """A file or a link (a link planted at an output's name is one too)."""
    return path.is_file() or path.is_symlink()


def writable_folder(out: Path | None, option: str = "--out") -> Path | None:
    """``out`` must be a folder calibench can write: said before any work, in one line naming
    ``option``. Makes it; returns it if this call created it (a command ending in bad input
    removes it again, empty), else None."""
    if out is None:
        return None
    out = Path(out)
    inside = [part for part in out.absolute().parts if part in (MARK, LOCK, CLAIM)]
    if inside:  # the folder's own bookkeeping: the next command there would remove or replace it
        raise BadInput(f"{option} {out}: {inside[0]} is calibench's own name in a folder, not one")
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
        # a name of this command's own: commands started together in one folder each test theirs
        fd, probe = tempfile.mkstemp(prefix=".calibench-write-test.", dir=out)
        os.close(fd)
        os.unlink(probe)
    except OSError as e:
        raise BadInput(f"{option} {out}: cannot write there ({e.strerror})") from None
    return created


# the arguments that name a command's input files (one path or a list of them)
_INPUTS = ("recordings", "recording", "run", "images", "test", "test_new_frame", "arm", "config")


def inputs_outside(args) -> None:
    """BadInput if one of the command's inputs (or --twin, an output of the user's naming) is a
    file the command may replace in its --out: an input is never an output.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command, its --out set.
    """
    out = getattr(args, "out", None)
    if out is None:
        return
    named: list = []
    for key in _INPUTS:
        v = getattr(args, key, None)
        named += v if isinstance(v, list) else [] if v is None else [v]
    twin = getattr(args, "twin", None)
    try:
        folder = Path(out).absolute().resolve()
        ours = [folder / n for n in (*OUTPUTS, LOCK, CLAIM) if os.path.lexists(folder / n)]
    except (OSError, RuntimeError):  # a link loop, a name too long: said by writable_folder
        return
    for given in [*named, *([] if twin is None else [twin])]:
        try:
            p = Path(given).absolute().resolve()
            hit = p.parent == folder and p.name in (*OUTPUTS, LOCK, CLAIM)
            hit = hit or folder / CLAIM in p.parents or any(_same(p, o) for o in ours)
        except (OSError, RuntimeError, ValueError):
            continue
        if hit:
            role = "--twin" if given is twin else "an input"
            raise BadInput(
                f"{given}: {role} is one of the files calibench writes or replaces in --out "
                f"{out}: copy it elsewhere first, or give another --out"
            )


def _same(a: Path, b: Path) -> bool:
    """Whether ``a`` (an existing file) and ``b`` are one file (a hard link, say)."""
    try:
        return a.samefile(b)
    except OSError:
        return False


_VIEW = re.compile(r"view\d+\.png|x-?[\d.e+-]+_y-?[\d.e+-]+\.png|truth\.json")  # --save-images's


def views_folder_free(folder: Path | None) -> None:
    """BadInput unless ``run --save-images``'s folder is empty of the names it writes, or holds a
    former ``--save-images``'s views (its truth.json calibench's by content): a user's own
    truth.json or view00.png is never replaced, nor written through a link."""
    if folder is None or not folder.is_dir():
        return
    taken = sorted(n for n in os.listdir(folder) if _VIEW.fullmatch(n))
    links = [n for n in taken if (folder / n).is_symlink()]
    if links:
        raise BadInput(
            f"--save-images {folder}: {links[0]} is a symbolic link; calibench neither writes "
            "through a link nor replaces one: remove it or give another folder"
        )
    try:
        truth = json.loads((folder / "truth.json").read_bytes())
        ours = isinstance(truth, dict) and {"camera", "board", "seed", "corners_px"} <= truth.keys()
    except (OSError, ValueError):
        ours = False
    if taken and not ours:
        raise BadInput(
            f"--save-images {folder} holds {', '.join(taken[:3])}, named as the views calibench "
            "writes but not written by `calibench run belt-stage --save-images` (no truth.json "
            "of its own): give another folder, or remove them"
        )
