"""A study through a local Dask cluster against the local spawn pool, the same workers.

``python benchmarks/dask_pool.py [TRIALS] [WORKERS]`` (defaults 4000 and every core) runs the
arm's analytic study of TRIALS trials twice: through ``run_study``'s own pool of WORKERS
processes, and through a ``distributed.LocalCluster`` of WORKERS one-thread worker processes,
started before the clock (a cluster is up before a user submits to it). Both times are whole
studies, outputs included. It prints both, their ratio (issue 39's goal: at most 1.10) and
whether the two journals agree trial by trial.
"""

from __future__ import annotations

import json
import os
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")

from calibench.scenarios.study.montecarlo import run_study  # noqa: E402


def _rows(out: Path) -> dict:
    rows = [json.loads(x) for x in (out / "trials.jsonl").read_text().splitlines() if x.strip()]
    return {r["trial"]: {k: v for k, v in r.items() if k != "elapsed_s"} for r in rows}


def compare(trials: int = 4000, workers: int | None = None, scenario: str = "arm-cmm") -> dict:
    """Seconds of the study through the pool and through Dask, and whether the results agree.

    Returns
    -------
    dict
        ``pool_s``, ``dask_s``, ``trials``, ``workers``, ``same`` (bool).
    """
    from distributed import LocalCluster

    n = workers or os.cpu_count() or 1
    with tempfile.TemporaryDirectory() as d:
        pool_out, dask_out = Path(d) / "pool", Path(d) / "dask"
        t = time.perf_counter()
        run_study(scenario, trials, 0, "analytic", pool_out, workers=n, progress=False)
        pool_s = time.perf_counter() - t
        with LocalCluster(
            n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None
        ) as cluster:
            t = time.perf_counter()
            run_study(
                scenario,
                trials,
                0,
                "analytic",
                dask_out,
                scheduler=cluster.scheduler_address,
                progress=False,
            )
            dask_s = time.perf_counter() - t
        same = _rows(pool_out) == _rows(dask_out)
    return {"pool_s": pool_s, "dask_s": dask_s, "trials": trials, "workers": n, "same": same}


def main() -> None:
    trials = int(sys.argv[1]) if len(sys.argv) > 1 else 4000
    workers = int(sys.argv[2]) if len(sys.argv) > 2 else None
    r = compare(trials, workers)
    print(
        f"arm-cmm, {r['trials']} analytic trials, {r['workers']} workers: "
        f"pool {r['pool_s']:.1f} s, Dask {r['dask_s']:.1f} s, "
        f"ratio {r['dask_s'] / r['pool_s']:.2f} (goal <= 1.10); "
        f"results {'identical' if r['same'] else 'DIFFER'}"
    )


if __name__ == "__main__":
    main()
