"""Whose results an output folder holds.

Each command writes to a folder of its own (``calibench-out/<scenario>`` for ``run``,
``<scenario>-fit``, ``<scenario>-discover``, ``<scenario>-montecarlo``, ``camera``, ``iso230``):
simulated and real results never share one. A folder says who writes it in :data:`MARK`; one that
holds another command's results (or, made before the mark, another command's main file) is
refused unless ``--force`` says to replace them, and then only calibench's own outputs are
replaced, never a user's other files (``claims``: how a command takes a folder and gives it back).
"""

from __future__ import annotations

import json
from pathlib import Path

from calibench.errors import BadInput

MARK = ".calibench.json"

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
    "recording.csv",  # a run's simulated recording and what it conceals: parts of its results
    "recording.truth.json",
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
