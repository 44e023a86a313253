"""Coverage of the reported std when the datasheet is wrong (issue 15's acceptance).

``python benchmarks/datasheet_coverage.py [N_ARM] [N_STEWART]`` runs Monte-Carlo studies of the
arm (default 1000 trials) and the Stewart platform (default 200) three times each: the datasheet
sigma right, 1.5x too large and 1.5x too small for every instrument (the estimators are told the
datasheet's; the simulation draws the truth's). It prints, per study, the pooled 95 % coverage
and how many parameters' own coverage leaves the binomial 95 % band of its trial count. The
estimators scale their covariance by the residuals' variance factor, so the three rows should
agree; without that factor the 1.5x rows would sit near 0.997 and 0.81.
"""

import os
import platform
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from calibench.scenarios.study.montecarlo import run_study

STATED = {
    "arm-cmm": {
        "stated_range_sigma_um": [5.0, 1.0],
        "stated_angle_sigma_urad": 4.0,
        "stated_encoder_sigma_urad": 5.0,
    },
    "stewart": {"stated_length_sigma_um": [0.3, 0.3], "stated_reading_sigma_um": 1.0},
}


def scaled(table: dict, factor: float) -> dict:
    """Every stated sigma of ``table`` times ``factor``."""
    return {
        k: [factor * x for x in v] if isinstance(v, list) else factor * v for k, v in table.items()
    }


def main():
    counts = {
        "arm-cmm": int(sys.argv[1]) if len(sys.argv) > 1 else 1000,
        "stewart": int(sys.argv[2]) if len(sys.argv) > 2 else 200,
    }
    print(f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, spawn pool")
    print(
        f"{'scenario':9s} {'datasheet':>9s} {'trials':>6s} {'coverage':>9s} "
        f"{'params out of band':>19s} {'s':>6s}"
    )
    for name, n in counts.items():
        for factor in (1.0, 1.5, 1 / 1.5):
            with tempfile.TemporaryDirectory() as tmp:
                t0 = time.perf_counter()
                s = run_study(
                    name,
                    n,
                    0,
                    "analytic",
                    Path(tmp),
                    progress=False,
                    table=scaled(STATED[name], factor),
                )
                elapsed = time.perf_counter() - t0
            params = [p for p in s["parameters"] if p["coverage_95"] is not None]
            pooled = np.mean([p["coverage_95"] for p in params])
            out = sum(
                not lo <= p["coverage_95"] <= hi
                for p in params
                for lo, hi in [p["coverage_95_expected"]]
            )
            print(
                f"{name:9s} {factor:9.3f} {s['trials']:6d} {pooled:9.3f} {out:>12d} of "
                f"{len(params):<4d} {elapsed:6.0f}"
            )


if __name__ == "__main__":
    main()
