"""``calibench uncertainty SCENARIO``: the uncertainty of the task a calibrated instrument does,
at each place of a grid over its workspace, by the adaptive Monte Carlo method of JCGM 101 7.9,
beside the GUM framework's answer and its validation (JCGM 101 8), and a check on fresh machines
(DIR/uncertainty.json, docs/formats.md).

Each instrument's task is a module of its own (its registry line's ``uncertainty``) with
``grid(config) -> (postures, points)``, ``labels(points)``, ``trial(config, grid, seed) ->
(Q,)`` (one machine drawn from the as-built distribution, calibrated on simulated recordings,
its compensated task error at the grid), ``gum(config, grid, seed) -> (J (Q, P), C (P, P))`` and
``TASK``, ``UNIT``.

Trials run in batches of :data:`BATCH` on the study's executor (a spawn pool, or Dask with
``--scheduler``). Every finished trial is journaled (DIR/uncertainty_trials.jsonl): the same
command again draws only what is missing, so an interrupted study loses nothing, and a batch's
trials are a function of the seed and their place alone. JCGM 101 asks batches of
``max(100 / (1 - p), 10^4)``: a trial here is a whole calibration (a second or two), so batches
are of :data:`BATCH`. The stop weighs the batches' endpoints as 7.9.4 k says (each the 5th of
200 values at 95 %); the interval stated is from all h M values (7.9.4 l), which the journal
keeps, so the batches' order-statistic bias (1.7 % of u outward) does not reach it.
"""

from __future__ import annotations

import dataclasses
import hashlib
import importlib
import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from calibench.estimators.uncertainty.adaptive import adaptive
from calibench.estimators.uncertainty.coverage import coverage_interval
from calibench.estimators.uncertainty.gum import gum_interval, validate
from calibench.scenarios import progress
from calibench.scenarios.report import BadInput
from calibench.writing import write_text

BATCH = 200  # trials per batch
N_DIG = 1  # u's significant digits when no --tolerance is given: the tracker's stated sigma's
FRESH_MACHINES = 100  # the coverage check's machines, drawn apart from the study's
JOURNAL = "uncertainty_trials.jsonl"


def plane_labels(points_mm: np.ndarray) -> list[dict]:
    """A stage task's quantities, x and y at each of its places (G, 2 or 3) mm, (2 G) in that
    order: the labels of a task whose grid lies in the travel's plane."""
    return [
        {"at": {"x_mm": round(float(p[0]), 1), "y_mm": round(float(p[1]), 1)}, "quantity": a}
        for p in points_mm
        for a in "xy"
    ]


def task_of(scenario: str):
    """The scenario's task module (its registry line's ``uncertainty``), or BadInput naming the
    instruments that have one."""
    from calibench.scenarios.registry import instrument, instruments

    module = instrument(scenario).uncertainty
    if module is None:
        built = ", ".join(row.name for row in instruments() if row.uncertainty)
        raise BadInput(f"uncertainty: no task is built for {scenario} yet (built: {built})")
    return importlib.import_module(module)


def trial_seed(seed: int, batch: int, j: int) -> int:
    """A trial's machine and noise seed from the study's seed and its place (batch -1: the
    coverage check's fresh machines)."""
    return int(np.random.SeedSequence([seed, batch + 1, j]).generate_state(1)[0])


@dataclasses.dataclass
class Study:
    """What every batch of a study shares: its task (module), config, grid postures and seed,
    ``key`` (the study's identity in the journal: rows of another study are not its own), the
    trials done {(batch, j): values}, the journal open for appending, the executor and the
    interrupt flag."""

    task: Any
    config: Any
    grid_q: np.ndarray
    seed: int
    key: str
    done: dict
    journal: Any = None
    executor: Any = None
    stop: Any = None

    def trials(self, batch: int, count: int) -> np.ndarray:
        """``count`` trials of ``batch``, (M, Q): the journaled ones taken back, the others run
        on the executor and journaled as each finishes; KeyboardInterrupt once the flag is set."""
        import concurrent.futures as cf

        from calibench.scenarios.study.executor import cluster_result

        todo = [j for j in range(count) if (batch, j) not in self.done]
        if todo:  # said on the command's progress line: which batch, and its trials done
            progress.expect(count, "trials", done=count - len(todo))
            progress.step("fresh machines" if batch < 0 else f"batch {batch + 1}")
        run = self.task.trial
        futures = {
            self.executor.submit(run, self.config, self.grid_q, trial_seed(self.seed, batch, j)): j
            for j in todo
        }
        # no future is cancelled here: an interrupt's close stops the workers, and a future
        # cancelled before that breaks the pool's own clean-up (Python 3.11: a traceback)
        for fut in cf.as_completed(futures):
            j = futures[fut]
            values = np.asarray(cluster_result(fut), float)  # a cluster gone: one line
            self.done[(batch, j)] = values
            row = {"study": self.key, "batch": batch, "trial": j, "values": values.tolist()}
            self.journal.write(json.dumps(row) + "\n")
            self.journal.flush()
            progress.advance()
            if self.stop.is_set():
                raise KeyboardInterrupt
        return np.stack([self.done[(batch, j)] for j in range(count)])


def study_key(scenario: str, config, seed: int, grid_q: np.ndarray) -> str:
    """The study's identity: its scenario, config, seed, batch and grid (a task whose grid
    changed is another study), hashed."""
    text = json.dumps([scenario, repr(config), seed, BATCH])
    grid = np.ascontiguousarray(grid_q, float).tobytes()
    return hashlib.sha256(text.encode() + grid).hexdigest()[:16]


def load_trials(out: Path, key: str) -> dict[tuple[int, int], np.ndarray]:
    """The study's journaled trials {(batch, j): values}; rows of another study and a torn last
    line (an interrupted write) are left out."""
    done: dict[tuple[int, int], np.ndarray] = {}
    path = out / JOURNAL
    if not path.exists():
        return done
    for line in path.read_text().splitlines():
        try:
            row = json.loads(line)
            if row["study"] == key:
                done[(int(row["batch"]), int(row["trial"]))] = np.asarray(row["values"], float)
        except (json.JSONDecodeError, KeyError, TypeError, ValueError):
            continue
    return done


def run_uncertainty(scenario: str, config, seed: int, out: Path, options: dict) -> dict:
    """The study (``options``: ``tolerance`` (unit, or None: u at :data:`N_DIG` digits),
    ``trials_max``, ``workers``, ``scheduler``, ``tls``); writes DIR/uncertainty.json and
    DIR/uncertainty.png and returns the result."""
    from calibench.scenarios.study.executor import interrupt_flag, make_executor

    task = task_of(scenario)
    grid_q, points = task.grid(config)
    key = study_key(scenario, config, seed, grid_q)
    study = Study(task, config, grid_q, seed, key, load_trials(out, key))
    path = out / JOURNAL
    if path.exists() and path.stat().st_size and not path.read_bytes().endswith(b"\n"):
        with open(path, "a") as torn:  # a line cut off by an interrupt: the next starts anew
            torn.write("\n")
    executor, close = make_executor(
        options.get("workers"), options.get("scheduler"), options.get("tls"), renders=False
    )
    interrupted = True
    try:
        with interrupt_flag() as stop, open(out / JOURNAL, "a") as journal:
            study.journal, study.executor, study.stop = journal, executor, stop
            mc = adaptive(
                study.trials,
                n_dig=N_DIG,
                size=BATCH,
                trials_max=options["trials_max"],
                tolerance=options.get("tolerance"),
            )
            fresh = study.trials(-1, FRESH_MACHINES)
        interrupted = False
    finally:
        close(interrupted=interrupted)
    # the interval from all h M values (JCGM 101 7.9.4 l): the batches' endpoints, averaged,
    # carry the bias of an order statistic of M (the 5th of 200: 1.7 % of u outward)
    pooled = np.vstack([study.trials(b, BATCH) for b in range(mc.batches.count)])
    low, high = coverage_interval(pooled, 0.95)
    J, cov = task.gum(config, grid_q, seed)
    g = gum_interval(np.zeros(len(mc.y)), J, cov)
    check = validate(g, low, high, mc.delta)
    inside = (fresh >= low) & (fresh <= high)
    result = {
        "scenario": scenario,
        "task": task.TASK,
        "unit": task.UNIT,
        "grid": [
            {
                **lab,
                "mean": y,
                "u": u,
                "interval_95": [lo, hi],
                "gum_u": gu,
                "gum_interval_95": [glo, ghi],
                "gum_valid": bool(ok),
            }
            for lab, y, u, lo, hi, gu, glo, ghi, ok in zip(
                task.labels(points),
                *(a.tolist() for a in (mc.y, mc.u, low, high, g.u, g.low, g.high)),
                check.validated,
            )
        ],
        "trials": mc.trials,
        "batch": BATCH,
        "tolerance": {
            "requested": options.get("tolerance"),
            "n_dig": N_DIG,
            "delta": float(np.max(mc.delta)),
            "achieved": float(np.max(mc.deviations) * 2),
        },
        "stopped": "tolerance" if mc.converged else "trials_max",
        "status": mc.status,
        "gum_validation": {
            "delta": float(np.max(check.delta)),
            "worst_d_low": float(check.d_low.max()),
            "worst_d_high": float(check.d_high.max()),
            "valid": check.overall,
            "valid_points": int(check.validated.sum()),
        },
        "coverage_check": {
            "fresh_machines": FRESH_MACHINES,
            "fraction_inside_95": float(inside.mean()),
        },
        "seed": seed,
    }
    if not all(math.isfinite(v) for v in (*mc.u, *g.u)):
        raise RuntimeError("uncertainty: a standard uncertainty is not finite")
    write_text(out / "uncertainty.json", json.dumps(result, indent=1) + "\n")
    from calibench.scenarios.uncertainty_figure import (
        write_uncertainty_figure,
        write_uncertainty_rrd,
    )

    write_uncertainty_figure(out / "uncertainty.png", points, result)
    write_uncertainty_rrd(out / "uncertainty.rrd", points, result, out / "uncertainty.png")
    return result
