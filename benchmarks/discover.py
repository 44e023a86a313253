"""discover's figures on this machine: ``python benchmarks/discover.py [N_NULL]``.

1. The concealed-effect suite (scenarios/discover_suite.py's SUITE: stages, the seed's arm and a
   UR10, the probe scanner and the Stewart platform, with compliance made by MuJoCo's physics): detection, false claims, parameters,
   held-out improvement, and the time per recording.
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

from calibench.estimators import discovery as dsc
from calibench.scenarios.discover import discover_arm, discover_stage, paper_belt_recording
from calibench.scenarios.discover_suite import SUITE, run_case, score, table
from calibench.scenarios.discover_scanner import discover_scanner
from calibench.scenarios.discover_stewart import STEWART_FLOOR, discover_stewart
from calibench.sim.concealed import arm_recording, scanner_recording, stage_recording, stewart_recording

SHARED = Path(__file__).resolve().parents[2] / "shared" / "data"


def suite():
    t = time.perf_counter()
    results = [run_case(*case) for case in SUITE]
    dt = time.perf_counter() - t
    print(table(results))
    s = score(results)
    print(f"\n{s['recordings']} recordings in {dt:.0f} s ({dt / s['recordings']:.1f} s each): "
          f"detection {s['detection']:.0%}, false claims on nulls {s['null_false_claim_rate']:.0%}, "
          f"spurious claims beside real ones {s['spurious_claims']}, parameters within limits "
          f"{s['params_within_limit']:.0%} (worst {s['worst_param'][0]} {s['worst_param'][1]:.3f} of "
          f"{s['worst_param'][2]}), cv after/before <= 0.5 in {s['ratios_ok']:.0%} of {s['n_dominated']} "
          f"dominated recordings (worst {s['worst_ratio']:.2f})")


def null_calibration(n):
    floors = (0.02, 0.04, 0.10)
    print(f"\nnull calibration: {n} null recordings per scenario (seeds 5000+)")
    print("| scenario | " + " | ".join(f"floor {f:.0%}" for f in floors) + " |")
    print("|---|" + "---|" * len(floors))
    for sc in ("belt-stage", "vision-stage", "arm-cmm", "arm-cmm:ur10", "probe-scanner", "stewart"):
        claims = {f: 0 for f in floors}
        arm = sc.partition(":")[2] or "arm-cmm"
        for k in range(n):
            if sc.startswith("arm-cmm"):
                rec, _ = arm_recording("null", 5000 + k, arm=arm)
            elif sc == "probe-scanner":
                rec, _ = scanner_recording("null", 5000 + k)
            elif sc == "stewart":
                rec, _ = stewart_recording("null", 5000 + k)
            else:
                rec, _ = stage_recording(sc, "null", 5000 + k)
            for f in floors:
                if sc.startswith("arm-cmm"):
                    out, _ = discover_arm(rec, 0, f, arm=arm)
                elif sc == "probe-scanner":
                    out, _ = discover_scanner(rec, 0, f)
                elif sc == "stewart":
                    out, _ = discover_stewart(rec, 0, f)
                else:
                    out, _ = discover_stage(sc, rec, 0, None, f)
                claims[f] += any(e["name"] != "geometry" for e in out["effects"])
        print(f"| {sc} | " + " | ".join(f"{claims[f] / n:.0%}" for f in floors) + " |")
    print(f"house floor: {dsc.FLOOR:.0%} (the stages and the scanner); the arm's 3 %, the platform's "
          f"{STEWART_FLOOR:.0%}")


def paper():
    rec = paper_belt_recording(SHARED / "seed_belt_stage")
    print("\nthe seed paper's belt stage (121 stations), its quadratic map as the simulation:")
    for holdout in ("rows", "columns"):
        d, _ = discover_stage("belt-stage", rec, 0, holdout)
        f = d["fit"]
        print(f"- {d['holdout']}: residual rms {f['rms_nominal'] * 1000:.0f} um, held-out "
              f"{f['cv_rms_nominal'] * 1000:.0f} -> {f['cv_rms_final'] * 1000:.0f} um")
        for e in d["effects"]:
            print(f"  - {e['name']} ({e['axis']}) {e['params']}: {e['cv_rms_before'] * 1000:.0f} -> "
                  f"{e['cv_rms_after'] * 1000:.0f} um")
        for loc in d["located"]:
            print(f"  - {loc['signal']} against {loc['driver']}: score {loc['score']:.2f}, p {loc['p_value']:.3f}; "
                  f"{loc['where']}")


if __name__ == "__main__":
    print(f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores")
    suite()
    null_calibration(int(sys.argv[1]) if len(sys.argv) > 1 else 30)
    if SHARED.exists():
        paper()
