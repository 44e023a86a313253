"""A Monte-Carlo study's trials, as a worker runs them.

Each trial draws the truth from the scenario's declared prior (its ``prior(config, rng)``) and
the noise from its sensor models, runs the pipeline, and returns plain data: one row with
``trial, seed, ok, error, elapsed_s`` and ``<name>.truth / .estimate / .std`` per parameter.
A trial is reproducible from (study seed, trial index) alone. Everything here is picklable by
reference and imports the scenario lazily: a worker loads only what its trials need.
"""

from __future__ import annotations

import dataclasses
import os
import sys
import time
import traceback
from typing import Any

import numpy as np


def trial_seed(study_seed: int, index: int) -> int:
    """The trial's own seed, from the study's and its index (independent streams).

    Parameters
    ----------
    study_seed : int
        The study's seed (``--seed``).
    index : int
        The trial's index in the study, from 0.

    Returns
    -------
    int
        The seed of the trial's ``numpy.random.Generator``, below 2^32.
    """
    return int(np.random.SeedSequence([int(study_seed), int(index)]).generate_state(1)[0])


def study_seed_of(seed: int, index: int, tried: int = 10_000) -> int | None:
    """The ``--seed`` of a study whose trial ``index`` ran with ``seed``, if a user would type it.

    A journal row keeps only its trial's own seed; a message naming that number (a 32-bit hash)
    tells a user nothing, so the study seeds users type (the small ones) are tried instead.

    Parameters
    ----------
    seed : int
        The trial's own seed, from a journal row.
    index : int
        The trial's index in its study.
    tried : int
        Study seeds 0 .. ``tried`` - 1 are tried (0.2 s for 10,000, on the error path only).

    Returns
    -------
    int or None
        The study seed, or None where none of those tried gives ``seed``.
    """
    return next((s for s in range(tried) if trial_seed(s, index) == seed), None)


def study_config(
    scenario: str, table: dict | None = None, arm: str | None = None, checked_only: bool = False
):
    """The scenario's config for a study: its defaults, overridden by ``table`` (the scenario's
    table of a ``--config`` TOML, checked as ``run`` checks it), then ``arm``.

    Parameters
    ----------
    scenario : str
        The scenario's name.
    table : dict, optional
        The overrides of the scenario's defaults.
    arm : str, optional
        A built-in arm's name or an ARM.toml's absolute path (arm-cmm).
    checked_only : bool
        Only check the config (in another process, whose config need not travel back).

    Returns
    -------
    config or None
        The scenario's config dataclass; None when ``checked_only``.

    Raises
    ------
    BadInput
        A key or value of ``table`` the scenario does not take.
    """
    from calibench.scenarios.config import override
    from calibench.scenarios.registry import scenario as get

    config = override(get(scenario).config(), table or {}, scenario)
    config = config if arm is None else dataclasses.replace(config, arm=arm)
    return None if checked_only else config


def run_trial(
    scenario: str,
    study_seed: int,
    index: int,
    fidelity: str,
    arm: str | None = None,
    table: dict | None = None,
) -> dict:
    """One trial, in a worker process; never raises (a failure is a row with its error).

    Parameters
    ----------
    scenario : str
        The scenario's name.
    study_seed : int
        The study's seed; the trial's own is :func:`trial_seed` of it and ``index``.
    index : int
        The trial's index in the study.
    fidelity : str
        ``"render"`` or ``"analytic"``.
    arm : str, optional
        The arm (arm-cmm), as :func:`study_config` takes it.
    table : dict, optional
        The study's config overrides (:func:`study_config`).

    Returns
    -------
    dict
        The journal's row: ``trial``, ``seed``, ``ok``, ``error`` (and ``traceback``),
        ``elapsed_s``; per parameter ``<name>.truth``, ``.estimate``, ``.std``, ``.unit`` (and
        ``.crlb``); per check ``check.<name>`` and ``check.<name>.ok``.
    """
    os.environ.setdefault("MUJOCO_GL", "egl")  # a worker renders without a display

    seed = trial_seed(study_seed, index)
    row: dict[str, Any] = {"trial": index, "seed": seed, "ok": True, "error": None}
    t0 = time.perf_counter()
    try:
        from calibench.scenarios.registry import scenario as get

        s = get(scenario)
        module = sys.modules[s.run.__module__]
        rng = np.random.default_rng(seed)
        config = module.prior(study_config(scenario, table, arm), rng)
        if hasattr(module, "trial_parameters"):
            params = module.trial_parameters(config, seed)
        else:
            rep = s.execute(config, seed, fidelity, None, False)
            params = rep.parameters
            for c in rep.checks:  # what the calibration achieved (a compensation, a pose error)
                row[f"check.{c.name}"] = float(c.value)
                row[f"check.{c.name}.ok"] = c.ok
        for p in params:
            row[f"{p.name}.truth"] = float(p.truth)
            row[f"{p.name}.estimate"] = float(p.estimate)
            row[f"{p.name}.std"] = None if p.std is None else float(p.std)
            row[f"{p.name}.unit"] = p.unit
            if p.crlb is not None:
                row[f"{p.name}.crlb"] = float(p.crlb)
    except Exception as e:  # noqa: BLE001 - recorded, the study goes on
        row["ok"] = False
        row["error"] = f"{type(e).__name__}: {e}".splitlines()[0]
        row["traceback"] = traceback.format_exc(limit=3)
    row["elapsed_s"] = time.perf_counter() - t0
    return row


def run_trials(
    scenario: str,
    study_seed: int,
    indices: list[int],
    fidelity: str,
    arm: str | None = None,
    table: dict | None = None,
) -> list[dict]:
    """Several trials in one task: millisecond trials would otherwise spend more time in
    inter-process traffic than in the estimator. One BLAS thread: a worker already has its core,
    and threaded BLAS on small matrices (the arm's QR at 200 postures) runs several times slower.

    Parameters
    ----------
    scenario, study_seed, fidelity, arm, table
        As for :func:`run_trial`.
    indices : list of int
        The trials' indices.

    Returns
    -------
    list of dict
        One :func:`run_trial` row per index, in their order.
    """
    from threadpoolctl import threadpool_limits

    from calibench.scenarios.progress import quiet

    _loosen_malloc_trim()
    # a worker draws no bar of its own: the study's parent shows the trials as they come back
    with threadpool_limits(1), quiet():
        return [run_trial(scenario, study_seed, i, fidelity, arm, table) for i in indices]


# glibc's heap trimming threshold in a worker that was started with a small one
TRIM_THRESHOLD_BYTES = 32 << 20
_TRIM_SET: list[bool] = []


def _loosen_malloc_trim() -> None:
    """Dask's nanny starts its workers with MALLOC_TRIM_THRESHOLD_=65536 (its
    ``pre-spawn-environ``), so glibc hands freed heap back to the kernel at every 64 KiB and
    takes it back on the next trial: the arm's trials, many small arrays each, ran 12 % slower
    there than in the local pool (benchmarks/dask_pool.py). Once per process, where that
    variable is set, the threshold is raised to :data:`TRIM_THRESHOLD_BYTES` (glibc's
    ``mallopt``); elsewhere, and off glibc, nothing changes."""
    if _TRIM_SET or not os.environ.get("MALLOC_TRIM_THRESHOLD_"):
        return
    _TRIM_SET.append(True)
    try:
        import ctypes

        ctypes.CDLL("libc.so.6").mallopt(-1, TRIM_THRESHOLD_BYTES)  # -1: M_TRIM_THRESHOLD
    except (OSError, AttributeError):  # not glibc
        pass


DASK_CHUNK = 64  # a Dask task costs a few ms of scheduling and messages: about 1 % of 64 trials


def chunk_size(n_todo: int, fidelity: str, dask_workers: int | None = None) -> int:
    """Trials per task: one for renders (seconds each, finest progress and resume), up to 16 for
    analytic trials, keeping 64 tasks or more so every worker stays busy to the end; through a
    Dask cluster up to :data:`DASK_CHUNK`, keeping 8 tasks or more per worker.

    Parameters
    ----------
    n_todo : int
        The number of trials to run.
    fidelity : str
        ``"render"`` or ``"analytic"``.
    dask_workers : int, optional
        The Dask cluster's workers (None: a local pool).

    Returns
    -------
    int
        Trials per task, from 1 to 16 (to :data:`DASK_CHUNK` through Dask).
    """
    if fidelity == "render":
        return 1
    if dask_workers:
        return max(1, min(DASK_CHUNK, n_todo // (8 * dask_workers)))
    return max(1, min(16, n_todo // 64))


def load_scenario(scenario: str) -> None:
    """In a worker, at its start: the scenario's module, imported before its first trials arrive.

    Parameters
    ----------
    scenario : str
        The scenario's name (``registry.NAMES``).
    """
    from calibench.scenarios.registry import scenario as get

    get(scenario)
