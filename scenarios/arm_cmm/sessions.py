"""``calibench fit arm-cmm --leave-one-out``: what a user with a new set-up gets.

Each recording is a session (its own instrument frame, its own power-up). For each session in
turn the arm is calibrated on the others (:func:`calibench.scenarios.arm_cmm.fit.run_arm_fit`,
each training session with its own base registration), then the left-out session's frame is
registered on a share of its rows (``REGISTER_FRACTION``, fixed seed) and the calibration is
scored on the rest: the rows that score a session never chose, fitted or registered anything.
With ``--effects discover`` the discovery runs inside each fold, on the training sessions' rows
alone. Writes DIR/<session>/ (each fold's fit.json, residuals.csv, fit.png) and DIR/fit.json with
the table (``leave_one_out``).

The folds are independent (each its own training sessions, its own left-out one and its own
folder), so on recordings of thousands of rows they run :data:`POOL_WORKERS` at a time, each in a
spawned process; every fold runs on one BLAS thread wherever it runs, so the figures are the
same to the bit in a pool or in this process, on any number of cores.
"""

from __future__ import annotations

import concurrent.futures as cf
import json
import os
import warnings
from pathlib import Path

from threadpoolctl import threadpool_limits

from calibench.scenarios.arm_cmm import NAME
from calibench.scenarios.arm_cmm.fit import REGISTER_FRACTION, SPLIT_SEED, run_arm_fit
from calibench.scenarios.progress import advance, expect, step
from calibench.scenarios.report import BadInput
from calibench.writing import write_text

FIGURES = ("samples", "mean_mm", "rms_mm", "p95_mm", "max_mm")
POOL_WORKERS = 2  # folds at a time (the UR10's four on 2 cores: 6-11 s of CPU each)
# the recordings' size (bytes, their rows' stand-in) from which a pool pays for its start: two
# interpreters importing numpy, scipy and the fit (about 2 s of CPU), against folds of seconds
# each on thousands of rows (the UR10's four series: 1.8 MB)
POOL_MIN_BYTES = 400_000
# the fold workers' heap (glibc reads these at a process's start; others ignore them): a fold
# allocates and frees arrays of 10-20 MB at every iteration, which by default go back to the
# kernel and come back page by page (1.4 million page faults, 6 s of a 33 s fold's CPU in the
# kernel); kept in the heap, the workers hold their peak (250 MB each) to the end instead
WORKER_HEAP = {"MALLOC_MMAP_THRESHOLD_": str(32 << 20), "MALLOC_TRIM_THRESHOLD_": str(256 << 20)}


def leave_one_session_out(
    paths: list[Path],
    arm_spec: str | Path | None,
    model: str | None,
    out_dir: Path,
    effects: Path | str | None = None,
    register_on_scored: bool = False,
    workers: int | None = None,
) -> dict:
    """Every session scored by a calibration on the others: fit.json's content (also written to
    ``out_dir``), with ``leave_one_out`` {session: its figures (mm), the sessions trained on,
    its frame's registration, and whether the score is in-sample}. ``register_on_scored``: each
    left-out session's frame and own terms fitted by least squares on the rows that score it
    (in-sample: the lowest RMS any registration of the others' calibration leaves there).
    ``workers``: the folds run at a time, each in its own process past one (default
    :func:`fold_workers`); the figures do not depend on it."""
    if len(paths) < 2:
        raise BadInput(
            f"--leave-one-out: {len(paths)} recording; it needs at least two sessions, one to "
            "train on and one to score"
        )
    names = [Path(p).name for p in paths]
    if len(set(names)) != len(names):
        raise BadInput("--leave-one-out: two recordings share a file name; give each its own")
    jobs = [
        (
            [p for i, p in enumerate(paths) if i != k],
            arm_spec,
            left,
            model,
            out_dir / Path(left).stem,
            effects,
            register_on_scored,
        )
        for k, left in enumerate(paths)
    ]
    # the folds' time so far says the rest's: not weighed by their training rows, which on the
    # UR10 did not follow it (the fold of 4,900 rows took the longest but one, that of 15,000
    # rows the shortest: the solve's iterations, not its rows, set its time)
    expect(len(paths), "folds")
    n_workers = fold_workers(paths) if workers is None else max(1, min(workers, len(paths)))
    results = pooled(jobs, names, n_workers) if n_workers > 1 else in_process(jobs, names)
    table, folds = {}, {}
    for k, (r, (train, _, _, _, fold_dir, _, _)) in enumerate(zip(results, jobs)):
        scored = r.get("test", {}).get(names[k]) or r["in_sample"][names[k]]
        table[names[k]] = {
            **{f: scored[f] for f in FIGURES},
            "trained_on": [Path(p).name for p in train],
            "frame": scored["frame"],
            "in_sample": names[k] in r.get("in_sample", {}),
        }
        folds[names[k]] = {"dir": str(fold_dir), "model": r["model"], "fit": r["fit"]}
        if "effects_from" in r:
            folds[names[k]]["effects_from"] = r["effects_from"]
    result = {
        "scenario": NAME,
        "arm": r["arm"],
        "model": r["model"],
        "leave_one_out": table,
        "folds": folds,
        "split": {"register_fraction": REGISTER_FRACTION, "seed": SPLIT_SEED},
    }
    out_dir.mkdir(parents=True, exist_ok=True)
    write_text(out_dir / "fit.json", json.dumps(result, indent=2) + "\n")
    return result


def fold_workers(paths: list[Path]) -> int:
    """The folds to run at a time: :data:`POOL_WORKERS` (at most one a core, one a fold) where
    the recordings hold at least :data:`POOL_MIN_BYTES`, else 1 (in this process)."""
    try:
        size = sum(Path(p).stat().st_size for p in paths)
    except OSError:
        return 1  # said by the fit's loader, with its reason, in the fold that reads it
    if size < POOL_MIN_BYTES:
        return 1
    return max(1, min(POOL_WORKERS, os.cpu_count() or 1, len(paths)))


def run_fold(
    train: list[Path],
    arm_spec: str | Path | None,
    left: Path,
    model: str | None,
    fold_dir: Path,
    effects: Path | str | None,
    register_on_scored: bool,
) -> dict:
    """One fold: the calibration on ``train``, ``left`` registered and scored
    (:func:`~calibench.scenarios.arm_cmm.fit.run_arm_fit`'s result, its outputs in ``fold_dir``).

    On one BLAS thread: the arm's normal equations have a few dozen columns, which a second
    thread does not speed up, and on a busy machine each product waited for the other thread's
    core (1.5 s instead of 0.02 s on the UR10's 48,000 rows: the whole took 9 min instead of 2).
    The same thread count everywhere also keeps the figures the same to the bit."""
    with threadpool_limits(1):
        return run_arm_fit(
            train, arm_spec, [], [left], None, model, fold_dir, effects, register_on_scored
        )


def fold_in_worker(*job) -> tuple[dict, list[tuple]]:
    """:func:`run_fold` in a pool's worker, with the warnings it gave (message, category, file,
    line), for the command to say as it says those of the folds run in its own process."""
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("default")
        r = run_fold(*job)
    return r, [(str(w.message), w.category, w.filename, w.lineno) for w in said]


def in_process(jobs: list[tuple], names: list[str]) -> list[dict]:
    """The folds ``jobs`` (:func:`run_fold`'s arguments) one after another in this process, each
    a step of the command's progress; their results in order."""
    results = []
    for name, job in zip(names, jobs):
        step(f"{name} left out")
        results.append(run_fold(*job))
        advance()
    return results


def pooled(jobs: list[tuple], names: list[str], workers: int) -> list[dict]:
    """The folds ``jobs`` on ``workers`` spawned processes, their results in order. A fold's
    error is raised once the folds before it are done, so the error said is the first fold's
    that fails, as in :func:`in_process`; Ctrl-C stops the workers at once."""
    from calibench.scenarios.study.executor import interrupt_flag, make_executor

    close = None
    failed = False
    results: list[dict] = []
    saved = {k: os.environ.get(k) for k in WORKER_HEAP}
    try:
        with interrupt_flag() as stop:
            os.environ.update(WORKER_HEAP)  # for the workers started below
            executor, close = make_executor(workers, None, renders=False)
            futures = [executor.submit(fold_in_worker, *job) for job in jobs]
            pending = set(futures)
            while len(results) < len(futures):
                # the pool takes the folds in order, so the first not done are the running ones
                running = [n for n, f in zip(names, futures) if f in pending][:workers]
                step(f"{', '.join(running)} left out")
                while not stop.is_set():
                    finished, pending = cf.wait(
                        pending, timeout=0.2, return_when=cf.FIRST_COMPLETED
                    )
                    if finished:
                        break
                if stop.is_set():
                    raise KeyboardInterrupt
                for fut in finished:
                    if fut.exception() is None:
                        advance()
                # the folds done in order, up to the first still running: their results, or the
                # first one's error
                while len(results) < len(futures) and futures[len(results)].done():
                    r, said = futures[len(results)].result()
                    for message, category, filename, lineno in said:
                        warnings.warn_explicit(message, category, filename, lineno)
                    results.append(r)
    except BaseException:
        failed = True  # the other folds' outputs are not wanted: stop them rather than wait
        raise
    finally:
        if close is not None:
            close(failed)
        for k, v in saved.items():  # the user's own, for what this process starts later
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v
    return results
