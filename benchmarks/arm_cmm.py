"""Identification throughput of arm-cmm on this machine: ``python benchmarks/arm_cmm.py``.

One trial = 50 postures' simulated tracker data, identifiability, Levenberg-Marquardt (the
Monte-Carlo unit of work), analytic fidelity.
"""

import os
import time

import calibench.sim  # noqa: F401  (MUJOCO_GL before mujoco)
import numpy as np

from calibench.estimators.arm_identification import identify_identifiable
from calibench.scenarios.arm_cmm import chain_of, tracker_problem
from calibench.scenes.arm_cmm import ArmGeometry
from calibench.sim.arm_cmm import ArmSim, ArmTruth


def main():
    g = ArmGeometry()
    arm, chain = ArmSim(g, ArmTruth()), chain_of(g)
    rng = np.random.default_rng(0)
    q = arm.random_postures(50, rng)
    n = 200
    t = time.perf_counter()
    for _ in range(n):
        identify_identifiable(tracker_problem(arm, chain, q, arm.encoders(q, rng), rng))
    dt = time.perf_counter() - t
    print(f"{os.cpu_count()} cores; arm-cmm identification, 50 postures: {n / dt:.1f} trials/s on one core "
          f"({dt / n * 1000:.1f} ms each)")


if __name__ == "__main__":
    main()
