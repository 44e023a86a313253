"""Running calibench for the blocks: one scratch folder per process, calibench's commands in this
process (their printout kept back), and the runs several blocks share, cached: a scenario's run,
the UR10's fits and its discovery, a Monte-Carlo study."""

from __future__ import annotations

import contextlib
import csv
import functools
import io
import json
import os
import sys
import tempfile
from pathlib import Path

from .engine import ROOT

os.environ.setdefault("MUJOCO_GL", "egl")  # before MuJoCo's first import: renders without a display

DATA = ROOT / "data"
UR10 = DATA / "ur10_landgraf"

SEED = 0  # every run's seed, and the studies'
HOLDOUT = 0.3  # the share of the UR10's rows held out when the fit trains on all four series
COVERAGE_PCT = 95  # the level of every coverage (scenarios.study.montecarlo's coverage_95)

_SCRATCH: list = []  # the scratch folder, removed when the process ends


def scratch() -> Path:
    """One scratch folder per process for every command's output."""
    if not _SCRATCH:
        _SCRATCH.append(tempfile.TemporaryDirectory(prefix="calibench-figures-"))
    return Path(_SCRATCH[0].name)


def calibench(*args) -> None:
    """Run one ``calibench`` command in this process, its printout kept back unless it fails."""
    from calibench.scenarios.cli import main

    argv = [str(a) for a in args]
    out = io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(out):
        status = main(argv)
    if status != 0:
        raise RuntimeError(f"calibench {' '.join(argv)} exited {status}:\n{out.getvalue()}")


def need_data(*paths: Path) -> None:
    """The real-data blocks need the project's data/ folder."""
    missing = [p for p in paths if not p.exists()]
    if missing:
        raise RuntimeError(
            f"missing {', '.join(map(str, missing))} (the real data lives in the project's data/)"
        )


# --- a scenario's run -----------------------------------------------------------------------------
@functools.cache
def report(scenario: str) -> dict:
    """``calibench run SCENARIO --seed 0`` (default fidelity, render where the scenario renders):
    its report.json."""
    out = scratch() / "run" / scenario
    calibench("run", scenario, "--seed", SEED, "--out", out, "--no-rrd")
    return json.loads((out / "report.json").read_text())


def checks(scenario: str) -> dict:
    """The run's checks by name."""
    return {c["name"]: c for c in report(scenario)["checks"]}


def params(scenario: str) -> dict:
    """The run's parameters by name."""
    return {p["name"]: p for p in report(scenario)["parameters"]}


# --- the real UR10 --------------------------------------------------------------------------------
def series(*letters: str) -> list[Path]:
    """The UR10's recordings ur10_X.csv."""
    paths = [UR10 / f"ur10_{x}.csv" for x in letters]
    need_data(UR10 / "ur10.toml", *paths)
    return paths


@functools.cache
def ur10_fit(setup: str, effects: str | None = None, model: str | None = None) -> dict:
    """``calibench fit arm-cmm`` on the real UR10: its fit.json. ``setup`` "C": trained on C,
    tested on B (C's frame), A and D (new frames); "all": trained on all four, HOLDOUT held out.
    ``effects``: a file for ``--effects`` (``"discovery-C"``: the discovery on C; ``"discover"``:
    fit's own discovery on its training rows)."""
    out = ur10_fit_dir(setup, effects, model)
    args = ["fit", "arm-cmm"]
    if setup == "C":
        c, b, a, d = series("C", "B", "A", "D")
        args += [c, "--test", b, "--test-new-frame", a, "--test-new-frame", d]
    else:
        args += [*series("C", "B", "A", "D"), "--holdout", HOLDOUT]
    args += ["--arm", UR10 / "ur10.toml", "--out", out]
    if model:
        args += ["--model", model]
    if effects == "discovery-C":
        args += ["--effects", ur10_discovery_c_json()]
    elif effects == "discover":  # discovery on the training rows only, inside fit
        args += ["--effects", "discover"]
    elif effects:
        args += ["--effects", ROOT / effects]
    calibench(*args)
    return json.loads((out / "fit.json").read_text())


def judged(fit: dict) -> tuple[dict, set]:
    """A fit.json's scores of held-out rows by recording, and the recordings where those rows
    chose the effects' structure (written under ``in_sample``): in-sample, never a result."""
    return {**fit.get("holdout", {}), **fit.get("in_sample", {})}, set(fit.get("in_sample", {}))


def ur10_fit_dir(setup: str, effects: str | None = None, model: str | None = None) -> Path:
    """Where :func:`ur10_fit` writes (fit.json, residuals.csv)."""
    return scratch() / "fit" / f"{setup}-{model}-{Path(effects or 'none').stem}"


def ur10_residuals(setup: str, effects: str | None = None) -> dict:
    """residuals.csv of :func:`ur10_fit` by file: {file: (rows (n,), roles (n,), measured -
    modelled (n, 3) mm)}."""
    import numpy as np

    ur10_fit(setup, effects)
    out = {}
    with open(ur10_fit_dir(setup, effects) / "residuals.csv") as f:
        for r in csv.DictReader(f):
            out.setdefault(r["file"], []).append(
                (int(r["row"]), r["role"], float(r["ex_mm"]), float(r["ey_mm"]), float(r["ez_mm"]))
            )
    return {
        k: (
            np.array([v[0] for v in rows]),
            np.array([v[1] for v in rows]),
            np.array([v[2:] for v in rows]),
        )
        for k, rows in out.items()
    }


@functools.cache
def ur10_discovery_c_json() -> Path:
    """``calibench discover arm-cmm ur10_C.csv --arm ur10.toml``: its discovery.json's path."""
    out = scratch() / "discover" / "ur10_C"
    calibench("discover", "arm-cmm", *series("C"), "--arm", UR10 / "ur10.toml", "--out", out)
    return out / "discovery.json"


def ur10_discovery_c() -> dict:
    """The discovery on ur10_C (discovery.json's content)."""
    return json.loads(ur10_discovery_c_json().read_text())


# --- Monte-Carlo studies --------------------------------------------------------------------------
@functools.cache
def study(scenario: str, trials: int, factor: float | None = None) -> dict:
    """A Monte-Carlo study (seed 0, analytic, all cores): its summary. ``factor``: every stated
    sigma times this (benchmarks/datasheet_coverage.py's tables)."""
    from calibench.scenarios.study.montecarlo import run_study

    table_ = None
    if factor is not None:
        sys.path.insert(0, str(ROOT / "benchmarks"))
        from datasheet_coverage import STATED, scaled

        table_ = scaled(STATED[scenario], factor)
    out = scratch() / "montecarlo" / f"{scenario}-{trials}-{factor}"
    return run_study(scenario, trials, SEED, "analytic", out, progress=False, table=table_)
