"""Monte-Carlo throughput per scenario and fidelity on this machine.

``python benchmarks/montecarlo.py [N_ANALYTIC] [N_RENDER]`` runs N_ANALYTIC trials of every
scenario at analytic fidelity (default: each scenario's study size of the README's performance
table, ``results.STUDIES``, whose rates issue 16's goals are about; also given as ``-``) and
N_RENDER (default 4) of the scenarios that render, through the default spawn pool over all cores, in
a scratch folder. It prints trials per second twice: the trials' own compute rate over all cores
(what a long study tends to), and the whole command's rate, start-up of Python and of the pool's
workers included, beside the goal. A whole command's rate depends on its size: the pool's start-up
(about half a second) weighs on a short study of millisecond trials, so compare rates of the same
size.
"""

import os
import platform
import sys
import tempfile
import time
from pathlib import Path

from results import STUDIES

from calibench.scenarios.registry import RENDERING, SCENARIOS
from calibench.scenarios.study.journal import load_journal
from calibench.scenarios.study.montecarlo import run_study

RENDERED = RENDERING  # the others report fidelity "analytic" only


def main():
    n_analytic = int(sys.argv[1]) if len(sys.argv) > 1 and sys.argv[1] != "-" else None
    n_render = int(sys.argv[2]) if len(sys.argv) > 2 else 4
    print(f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, spawn pool")
    print(
        f"{'scenario':14s} {'fidelity':9s} {'trials':>6s} {'trials/s':>9s} {'whole command':>14s} "
        f"{'goal':>5s}"
    )
    for name in SCENARIOS:
        size, goal = STUDIES[name]
        for fidelity, n in (("analytic", n_analytic or size), ("render", n_render)):
            if fidelity == "render" and name not in RENDERED or n == 0:
                continue
            with tempfile.TemporaryDirectory() as d:
                t = time.perf_counter()
                s = run_study(name, n, 0, fidelity, Path(d), progress=False)
                dt = time.perf_counter() - t
                busy = sum(r["elapsed_s"] for r in load_journal(Path(d)).values())
            print(
                f"{name:14s} {fidelity:9s} {n:6d} {n * (os.cpu_count() or 1) / busy:9.2f} "
                f"{n / dt:14.2f} "
                + (f"{goal:5d}" if fidelity == "analytic" else " " * 5)
                + (f"   ({s['failed']} failed)" if s["failed"] else "")
            )


if __name__ == "__main__":
    main()
