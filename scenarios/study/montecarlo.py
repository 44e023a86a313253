"""``calibench montecarlo``: accuracy studies of a scenario (docs/formats.md: trials.parquet,
summary.json).

:func:`run_study` runs the trials a study's folder misses (``trials``: what one trial does) on a
``concurrent.futures.Executor`` (``executor``: a local spawn pool or a Dask cluster), appends each
finished one to DIR/trials.jsonl at once (``journal``: nothing is lost on interruption, and a rerun
of the same command skips them), and writes trials.parquet, summary.json, study.png and study.rrd
from the journal (``summary``, ``outputs``).
"""

from __future__ import annotations

import concurrent.futures as cf
import functools
import json
import os
import sys
import threading
import time
from pathlib import Path

from calibench.errors import BadInput
from calibench.scenarios.progress import Progress, advance, expect, stage
from calibench.scenarios.study.executor import (
    WorkersGone,
    cluster_result,
    interrupt_flag,
    make_executor,
)
from calibench.scenarios.study.journal import (
    load_journal,
    open_journal,
    record_study,
    study_lock,
)
from calibench.scenarios.study.outputs import import_writers, write_outputs
from calibench.scenarios.study.summary import summarise
from calibench.scenarios.study.trials import (
    chunk_size,
    load_scenario,
    run_trials,
    study_config,
    study_seed_of,
    trial_seed,
)


def run_study(
    scenario: str,
    trials: int,
    seed: int,
    fidelity: str,
    out_dir: Path,
    workers: int | None = None,
    scheduler: str | None = None,
    executor: cf.Executor | None = None,
    progress: bool | None = None,
    arm: str | None = None,
    table: dict | None = None,
    tls: dict | None = None,
) -> dict:
    """Run the missing trials of a study, journal them as they finish, write the outputs.

    Parameters
    ----------
    scenario : str
        The scenario's name.
    trials : int
        The study's number of trials; those already in ``out_dir``'s journal are kept.
    seed : int
        The study's seed.
    fidelity : str
        ``"render"`` or ``"analytic"``.
    out_dir : Path
        The study's folder: trials.jsonl, study.json, trials.parquet, summary.json, study.png,
        study.rrd.
    workers : int, optional
        Local worker processes (default: one per core, at most one per trial to run).
    scheduler : str, optional
        A Dask scheduler's address instead of local workers.
    executor : concurrent.futures.Executor, optional
        Run the trials there instead (the caller closes it).
    progress : bool, optional
        False: no progress; default: a bar on an interactive terminal outside CI, a line at
        least every 30 s elsewhere (:mod:`calibench.scenarios.progress`).
    arm : str, optional
        A built-in arm's name or an ARM.toml's absolute path (arm-cmm).
    table : dict, optional
        Config overrides of the scenario (a ``--config`` file's table), the same for every trial
        and recorded in study.json, so a resumed study cannot mix two configs.
    tls : dict, optional
        ``--scheduler tls://``'s files: ``ca_file``, ``cert``, ``key`` (None for Dask's config).

    Returns
    -------
    dict
        The summary (:func:`~calibench.scenarios.study.summary.summarise`, summary.json) and
        ``resumed``: the trials kept from an earlier run.

    Raises
    ------
    BadInput
        An unknown scenario, a bad config, a folder holding another study, or a set-up no trial
        can calibrate.
    """
    from calibench.scenarios.registry import NAMES

    if scenario not in NAMES:
        raise BadInput(f"unknown scenario {scenario!r} (available: {', '.join(NAMES)})")
    if trials < 1:
        raise BadInput("--trials must be at least 1")
    # the study's one bar (its workers draw none: run_trials); it never touches a draw
    with study_lock(out_dir), Progress(f"montecarlo {scenario}", enabled=progress):
        return _run_study(
            scenario,
            trials,
            seed,
            fidelity,
            out_dir,
            workers,
            scheduler,
            executor,
            arm,
            table,
            tls,
        )


def _run_study(
    scenario,
    trials,
    seed,
    fidelity,
    out_dir,
    workers,
    scheduler,
    executor,
    arm,
    table,
    tls,
) -> dict:
    """:func:`run_study` in its locked folder."""
    done = load_journal(out_dir)
    for i, row in done.items():
        # study.json may be gone: each row says its trial's seed, which this study's must be
        if row["seed"] != trial_seed(seed, i):
            theirs = study_seed_of(row["seed"], i)
            # the row's own seed is a hash the user never typed: name the study's --seed instead
            ran = f"a study with --seed {theirs}" if theirs is not None else "another --seed"
            raise BadInput(
                f"{out_dir / 'trials.jsonl'}: trial {i} was run by {ran}, not this study's "
                f"(--seed {seed}): the folder holds another study; use another --out, or "
                "--force to replace it"
            )
    todo = [i for i in range(trials) if i not in done]
    # A local pool starts (and its workers load the scenario) while this process checks the config;
    # a Dask cluster is reached only once the config holds and there are trials to run.
    early = executor is None and scheduler is None and bool(todo)
    close = None
    failed = False
    try:
        checked = None
        if early:
            workers = min(workers or os.cpu_count() or 1, len(todo))  # no idle processes to start
            stage("starting the workers")
            # a signal landing while a worker is spawned cuts its start-up data short, and the
            # worker prints a traceback: it is held until the pool has started
            with interrupt_flag() as stop:
                executor, close = make_executor(workers, None, renders=fidelity == "render")
                for _ in range(workers):
                    executor.submit(load_scenario, scenario)
                # a worker, which loads the scenario anyway, checks the config: this process
                # then never imports the scenario's estimators, which on 2 cores would slow the
                # workers' start
                checked = executor.submit(study_config, scenario, table, arm, checked_only=True)
            if stop.is_set():
                raise KeyboardInterrupt
        described = (out_dir / "study.json").exists()
        _prepare(scenario, seed, fidelity, out_dir, arm, table, checked)
        t0 = time.perf_counter()
        if todo:
            if executor is None:
                try:
                    executor, close = make_executor(
                        workers, scheduler, tls, warm=functools.partial(load_scenario, scenario)
                    )
                except BadInput:
                    if not described and not done:  # no study began here: leave no trace of one
                        (out_dir / "study.json").unlink(missing_ok=True)
                    raise
            _run_todo(
                executor,
                scenario,
                seed,
                fidelity,
                out_dir,
                arm,
                table,
                trials,
                done,
                todo,
                preload=close is not None and scheduler is None,
            )
    except (KeyboardInterrupt, BadInput):
        failed = True  # the workers' trials are not kept: stop them rather than wait for them
        raise
    finally:
        if close is not None:
            close(failed)
    # a study never shrinks below its journal: trials an earlier, longer run finished stay in
    # the summary (each trial is the same whatever --trials says, so they are this study's)
    rows = [done[i] for i in sorted(done)]
    stage("writing the outputs")
    if len(rows) > trials:
        print(
            f"calibench: {out_dir} holds {len(rows)} finished trials of this study: the summary "
            f"covers them all (--trials {trials} asked; --force starts the study anew)",
            file=sys.stderr,
        )
    summary = summarise(scenario, rows, time.perf_counter() - t0)
    if rows and all(not r["ok"] and r["error"].startswith("LinAlgError") for r in rows):
        raise BadInput(
            f"every trial's estimate is singular: the {scenario} set-up cannot determine its "
            "parameters"
            + (" (is the arm degenerate: planar, or without length?)" if arm else "")
            + f"; e.g. {rows[0]['error']}"
        )
    if table and rows and not any(r["ok"] for r in rows):
        raise BadInput(
            f"every trial failed with the config's values (e.g. {rows[0]['error']}): the "
            f"{scenario} set-up they describe cannot be calibrated"
        )
    if not summary["parameters"] and any(r["ok"] for r in rows):
        # an empty table is no result: the set-up leaves nothing to estimate (an arm of one joint,
        # whose every error the tracker's frame and the tool absorb); the journal stays
        raise BadInput(
            f"no trial estimated a parameter it could compare with the truth: the {scenario} "
            "set-up leaves nothing identifiable beside its frames"
            + (" (is the arm degenerate?)" if arm else "")
        )
    summary["resumed"] = len(rows) - sum(1 for i in todo if i in done)
    write_outputs(out_dir, rows, summary)
    return summary


def _prepare(
    scenario: str, seed: int, fidelity: str, out_dir: Path, arm, table, checked=None
) -> None:
    """Check the config and the output folder (one study per folder), and record the study.
    ``checked``: the future of the config's check in a worker (:func:`study_config`), if any."""
    # a bad config is said once, before any trial
    if checked is None:
        study_config(scenario, table, arm)
    else:
        checked.result()
    out_dir.mkdir(parents=True, exist_ok=True)
    meta = {"scenario": scenario, "seed": seed, "fidelity": fidelity}
    if arm is not None:
        meta["arm"] = arm
    if table:
        meta["config"] = table
    record_study(out_dir, meta)


def _run_todo(
    executor,
    scenario,
    seed,
    fidelity,
    out_dir,
    arm,
    table,
    trials,
    done,
    todo,
    preload: bool = False,
) -> None:
    """Run the trials ``todo`` on ``executor``, appending each finished one to the journal and
    to ``done``. ``preload``: the trials run in other processes, so this one is idle and may import
    the writers' modules."""
    expect(trials, "trials", done=trials - len(todo))
    if preload:
        threading.Thread(target=import_writers, daemon=True).start()
    with open_journal(out_dir) as journal:
        k = chunk_size(len(todo), fidelity, getattr(executor, "dask_workers", None))
        with interrupt_flag() as stop:  # a submit may spawn a worker: see _run_study
            futures = [
                executor.submit(run_trials, scenario, seed, todo[j : j + k], fidelity, arm, table)
                for j in range(0, len(todo), k)
            ]
            pending = set(futures)
            alone = WorkersGone(executor)
            while pending:
                if stop.is_set():
                    raise KeyboardInterrupt
                alone.check()
                finished, pending = cf.wait(pending, timeout=0.2, return_when=cf.FIRST_COMPLETED)
                for fut in sorted(finished, key=futures.index):
                    for row in cluster_result(fut):
                        journal.write(json.dumps(row) + "\n")
                        done[row["trial"]] = row
                    journal.flush()
                    advance(len(cluster_result(fut)))
