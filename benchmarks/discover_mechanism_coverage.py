"""Do the stated errors of issue 61's mechanisms cover their truths? ``python
benchmarks/discover_mechanism_coverage.py [SEEDS]`` (default 40 recordings per case), shared
over every core.

Prints, per case (an arm's encoder slipped at a hard stop: the ``step``'s size and moment; a
stage's scale lagging the air: ``thermal_expansion``'s time constant and coefficient; an arm's
gear with play: ``backlash``), the share of the parameters found whose stated 95 % interval
holds the truth, the RMS of their standardised errors and the recordings where the effect was
not found, under ``gaussian`` and the third suite's reading noises in turn
(:mod:`calibench.scenarios.discover.mechanism_coverage`). The machine and the time are printed
with them.
"""

import os
import platform
import sys
import time

import numpy as np

from calibench.scenarios.discover.mechanism_coverage import mechanism_coverage


def main(seeds: int) -> None:
    t = time.perf_counter()
    workers = os.cpu_count() or 1
    rows = mechanism_coverage(seeds, workers=workers)
    print("| case | parameter | recordings | found | coverage of the 95 % intervals | z RMS |")
    print("|---|---|---|---|---|---|")
    for c in rows:
        z_rms = float(np.sqrt(np.mean(c.z**2))) if len(c.z) else float("nan")
        print(
            f"| {c.kind} | {c.parameter} | {c.recordings} | {len(c.z)} | {c.coverage:.2f} | "
            f"{z_rms:.2f} |"
        )
    print(
        f"\n{seeds} recordings per case in {time.perf_counter() - t:.0f} s on "
        f"{platform.processor() or platform.machine()}, {workers} processes"
    )


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 40)
