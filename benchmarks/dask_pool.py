"""A study through a local Dask cluster against the local spawn pool, the same workers.

``python benchmarks/dask_pool.py [TRIALS] [WORKERS]`` (defaults 2000 and every core) runs the
arm's analytic study of TRIALS trials through ``run_study``'s own pool of WORKERS processes and
through a ``distributed.LocalCluster`` of WORKERS one-thread worker processes, started before the
clock (a cluster is up before a user submits to it), the two in turn for 6 rounds, each first in
every other round. Both times are whole studies, outputs included. It prints their medians, the
median of the rounds' ratios (issue 39's goal: at most 1.10) and whether the journals agree trial
by trial.
"""

from __future__ import annotations

import json
import os
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")

import numpy as np  # noqa: E402

from calibench.scenarios.study.montecarlo import run_study  # noqa: E402


def _rows(out: Path) -> dict:
    rows = [json.loads(x) for x in (out / "trials.jsonl").read_text().splitlines() if x.strip()]
    return {r["trial"]: {k: v for k, v in r.items() if k != "elapsed_s"} for r in rows}


def _pool_s(scenario: str, trials: int, workers: int, out: Path) -> float:
    t = time.perf_counter()
    run_study(scenario, trials, 0, "analytic", out, workers=workers, progress=False)
    return time.perf_counter() - t


def _dask_s(scenario: str, trials: int, workers: int, out: Path) -> float:
    from distributed import LocalCluster

    with LocalCluster(
        n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None
    ) as cluster:
        t = time.perf_counter()
        run_study(
            scenario,
            trials,
            0,
            "analytic",
            out,
            scheduler=cluster.scheduler_address,
            progress=False,
        )
        return time.perf_counter() - t


def compare(
    trials: int = 2000, workers: int | None = None, scenario: str = "arm-cmm", rounds: int = 6
) -> dict:
    """Seconds of the study through the pool and through Dask, and whether the results agree.

    The two run in turn ``rounds`` times, the pool first in every other round (this machine's
    speed drifts by a third within minutes: one pair says little, and a drift within a round
    favours whichever runs first); the ratio is the median of the rounds' own ratios.

    Returns
    -------
    dict
        ``pool_s``, ``dask_s`` (medians), ``ratio``, ``trials``, ``workers``, ``rounds``,
        ``same`` (bool: every round's two journals agree trial by trial).
    """
    n = workers or os.cpu_count() or 1
    pool_s, dask_s, same = [], [], True
    for r in range(rounds):
        with tempfile.TemporaryDirectory() as d:
            pool_out, dask_out = Path(d) / "pool", Path(d) / "dask"
            if r % 2 == 0:
                pool_s.append(_pool_s(scenario, trials, n, pool_out))
            dask_s.append(_dask_s(scenario, trials, n, dask_out))
            if r % 2 == 1:
                pool_s.append(_pool_s(scenario, trials, n, pool_out))
            same = same and _rows(pool_out) == _rows(dask_out)
    return {
        "pool_s": float(np.median(pool_s)),
        "dask_s": float(np.median(dask_s)),
        "ratio": float(np.median(np.array(dask_s) / np.array(pool_s))),
        "trials": trials,
        "workers": n,
        "rounds": rounds,
        "same": same,
    }


def main() -> None:
    trials = int(sys.argv[1]) if len(sys.argv) > 1 else 2000
    workers = int(sys.argv[2]) if len(sys.argv) > 2 else None
    r = compare(trials, workers)
    print(
        f"arm-cmm, {r['trials']} analytic trials, {r['workers']} workers: "
        f"pool {r['pool_s']:.1f} s, Dask {r['dask_s']:.1f} s (medians of {r['rounds']} rounds), "
        f"ratio {r['ratio']:.2f} (goal <= 1.10); "
        f"results {'identical' if r['same'] else 'DIFFER'}"
    )


if __name__ == "__main__":
    main()
