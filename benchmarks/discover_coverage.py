"""Do discover's standard errors cover under noise it does not assume? ``python
benchmarks/discover_coverage.py [SEEDS]`` (default 10 recordings per stage family and noise,
three times as many for the scanner), shared over every core.

Prints, per family (the belt and vision stages' combined backlash + periodic + thermal, the
probe scanner's runout) and per reading noise (``gaussian`` as assumed; ``t3``, ``drift``,
``outliers`` as real instruments give), the share of the found effects' parameters whose stated
95 % interval holds the truth, the RMS of their standardised errors (1 when the stated std is
the spread), and the concealed effects missed. The machine and the time are printed with them.
"""

import os
import platform
import sys
import time

import numpy as np

from calibench.scenarios.discover.stated_errors import coverage_study


def main(seeds: int) -> None:
    t = time.perf_counter()
    workers = os.cpu_count() or 1
    rows = coverage_study(seeds, workers=workers)
    print(
        "| family | noise | recordings | effects | coverage of the 95 % intervals | z RMS "
        "| missed |"
    )
    print("|---|---|---|---|---|---|---|")
    for c in rows:
        z_rms = float(np.sqrt(np.mean(c.z**2))) if len(c.z) else float("nan")
        print(
            f"| {c.scenario} | {c.noise} | {c.recordings} | {len(c.z)} | {c.coverage:.2f} | "
            f"{z_rms:.2f} | {c.missed} |"
        )
    print(
        f"\n{seeds} recordings per stage row (the scanner's: three times as many) in "
        f"{time.perf_counter() - t:.0f} s on "
        f"{platform.processor() or platform.machine()}, {workers} processes"
    )


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 10)
