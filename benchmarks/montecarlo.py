"""Monte-Carlo throughput per scenario on this machine: ``python benchmarks/montecarlo.py [N]``.

Runs N trials (default 40) of each scenario, analytic fidelity, through the default spawn pool
over all cores, in a scratch folder, and prints trials per second (start-up included).
"""

import os
import sys
import tempfile
import time
from pathlib import Path

from scenarios.montecarlo import run_study
from scenarios.registry import SCENARIOS


def main():
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 40
    print(f"{os.cpu_count()} cores, {n} trials each, analytic fidelity, spawn pool")
    for name in SCENARIOS:
        with tempfile.TemporaryDirectory() as d:
            t = time.perf_counter()
            s = run_study(name, n, 0, "analytic", Path(d), progress=False)
            dt = time.perf_counter() - t
        print(f"{name:14s} {n / dt:8.1f} trials/s   ({s['failed']} failed)")


if __name__ == "__main__":
    main()
