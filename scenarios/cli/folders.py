"""Whose results an output folder holds.

Each command writes to a folder of its own (``calibench-out/<scenario>`` for ``run``,
``<scenario>-fit``, ``<scenario>-discover``, ``<scenario>-montecarlo``, ``camera``, ``iso230``):
simulated and real results never share one. A folder says who writes it in :data:`MARK`, written
when the command claims it, before any output (so an interrupted first run's folder is still known
as calibench's); one that holds another command's results (or, made before the mark, another
command's main file) is refused unless ``--force`` says to replace them, and then only calibench's
own outputs are removed, never a user's other files, and only once the command has written its
own: one that ends having written nothing (bad input, an interruption) leaves the folder as it
found it. A folder no command marked that holds files by an output's name (a paper's
``x_axis_error_mm.csv``) is a user's: refused, ``--force`` or not.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

from calibench.errors import BadInput

MARK = ".calibench.json"
# where --force keeps the results it replaces until the command has written its own (a command
# that ends having written nothing puts them back)
REPLACED = ".calibench-replaced"

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
    """Make ``folder`` this command's, before any output is written: refused if it holds another
    command's results, unless ``force``, which sets them aside (calibench's outputs only, in
    :data:`REPLACED`), and refused if no command marked it but it holds files by an output's name
    (a user's own). Then :data:`MARK` says whose results it takes; :func:`release` ends the
    claim.

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
        The folder holds another command's results and ``force`` is not given, or a user's files
        by an output's name.
    """
    folder.mkdir(parents=True, exist_ok=True)
    held = owner(folder)
    if held is None:
        strays = [name for name in OUTPUTS if _is_file(folder / name)]
        if strays:
            raise BadInput(
                f"--out {folder} holds {', '.join(strays[:3])}, named as calibench's outputs but "
                f"written by no calibench command (there is no {MARK}): give another --out "
                "(--force replaces only what calibench wrote)"
            )
    mine = (command, scenario)
    same = held is not None and held[0] == command and held[1] in (None, scenario)
    if held is not None and not same:
        if not force:
            raise BadInput(
                f"--out {folder} holds the results of {_said(*held)}; {_said(*mine)} would mix "
                "its own with them: give another --out, or --force to replace them"
            )
        set_aside(folder)
    elif force:
        set_aside(folder)
    (folder / MARK).write_text(json.dumps({"command": command, "scenario": scenario}) + "\n")


def release(folder: Path) -> None:
    """End :func:`claim`'s hold on ``folder`` once the command is over, whatever its end: if it
    wrote any output the results it replaced are gone; if it wrote none, they are put back and the
    folder's mark is theirs again (a command refused as bad input leaves no claim on a folder)."""
    aside = folder / REPLACED
    if not any(_is_file(folder / name) for name in OUTPUTS if name != MARK):
        (folder / MARK).unlink(missing_ok=True)
        if aside.is_dir():
            for path in aside.iterdir():
                path.rename(folder / path.name)
    shutil.rmtree(aside, ignore_errors=True)


def _is_file(path: Path) -> bool:
    return path.is_file() or path.is_symlink()


def set_aside(folder: Path) -> None:
    """Move calibench's outputs in ``folder`` (:data:`OUTPUTS`), nothing else, to its
    :data:`REPLACED`; refused while a study runs there (its lock is held)."""
    from calibench.scenarios.study.journal import study_running

    if study_running(folder):
        raise BadInput(
            f"{folder}: a calibench study is running in this folder; --force would remove its "
            "trials under it: wait for it, or use another --out"
        )
    shutil.rmtree(folder / REPLACED, ignore_errors=True)  # left by a command killed outright
    held = [name for name in OUTPUTS if _is_file(folder / name)]
    if held:
        (folder / REPLACED).mkdir()
    for name in held:
        (folder / name).rename(folder / REPLACED / name)


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
