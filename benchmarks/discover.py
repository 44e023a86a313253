"""discover's figures on this machine: ``python benchmarks/discover.py [N_NULL]``.

1. The concealed-effect suite (scenarios/discover/suite.py's suite_cases(): stages, the seed's arm
   and a UR10, the probe scanner and the Stewart platform, with compliance made by MuJoCo's
   physics): detection, false claims, parameters, held-out improvement, and the time per recording.
2. The null calibration of the acceptance floor: N_NULL (default 30) null recordings per
   scenario through discover at several floors; the false-claim rate at each. The house floor
   (estimators.discovery.FLOOR) is the smallest whose rate stays under 5 %.
3. The seed paper's measured belt-stage tables with its quadratic model as the simulation:
   where the residual lives, and what a better model gains holding out whole rows or columns.
"""

import os
import platform
import sys
import time
from pathlib import Path

import numpy as np

from calibench.estimators.discovery.select import FLOOR
from calibench.scenarios.discover.suite import null_claims, run_case, score, suite_cases, table
from calibench.scenarios.stages.discovery import discover_stage, paper_belt_recording
from calibench.scenarios.stewart.discovery import STEWART_FLOOR

SHARED = Path(__file__).resolve().parents[1] / "data"


def suite():
    t = time.perf_counter()
    results = [run_case(*case) for case in suite_cases()]
    dt = time.perf_counter() - t
    print(table(results))
    s = score(results)
    print(
        f"\n{s['recordings']} recordings in {dt:.0f} s ({dt / s['recordings']:.1f} s each): "
        f"detection {s['detection']:.0%}, false claims on nulls {s['null_false_claim_rate']:.0%}, "
        f"spurious claims beside real ones {s['spurious_claims']}, parameters within limits "
        f"{s['params_within_limit']:.0%} (worst {s['worst_param'][0]} {s['worst_param'][1]:.3f} of "
        f"{s['worst_param'][2]}), cv after/before <= 0.5 in {s['ratios_ok']:.0%} of "
        f"{s['n_dominated']} dominated recordings (worst {s['worst_ratio']:.2f})"
    )


def null_calibration(n):
    floors = (0.02, 0.04, 0.10)
    print(f"\nnull calibration: {n} null recordings per scenario (seeds 5000+)")
    print("| scenario | " + " | ".join(f"floor {f:.0%}" for f in floors) + " |")
    print("|---|" + "---|" * len(floors))
    for sc in dict.fromkeys(label for label, _, _ in suite_cases()):  # each instrument and arm
        claims = np.sum([null_claims(sc, k, floors) for k in range(n)], axis=0)
        print(f"| {sc} | " + " | ".join(f"{c / n:.0%}" for c in claims) + " |")
    print(
        f"house floor: {FLOOR:.0%} (the stages and the scanner); the arm's 3 %, the platform's "
        f"{STEWART_FLOOR:.0%}"
    )


def paper():
    rec = paper_belt_recording(SHARED / "seed_belt_stage")
    print("\nthe seed paper's belt stage (121 stations), its quadratic map as the simulation:")
    for holdout in ("rows", "columns"):
        d, _ = discover_stage("belt-stage", rec, 0, holdout)
        f = d["fit"]
        print(
            f"- {d['holdout']}: residual rms {f['rms_nominal'] * 1000:.0f} um, held-out "
            f"{f['cv_rms_nominal'] * 1000:.0f} -> {f['cv_rms_final'] * 1000:.0f} um"
        )
        for e in d["effects"]:
            print(
                f"  - {e['name']} ({e['axis']}) {e['params']}: {e['cv_rms_before'] * 1000:.0f} -> "
                f"{e['cv_rms_after'] * 1000:.0f} um"
            )
        for loc in d["located"]:
            print(
                f"  - {loc['signal']} against {loc['driver']}: score {loc['score']:.2f}, p "
                f"{loc['p_value']:.3f}; {loc['where']}"
            )


if __name__ == "__main__":
    print(f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores")
    suite()
    null_calibration(int(sys.argv[1]) if len(sys.argv) > 1 else 30)
    if SHARED.exists():
        paper()
