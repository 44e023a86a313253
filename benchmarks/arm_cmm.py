"""Arm identification throughput on this machine: ``python benchmarks/arm_cmm.py``.

1. The Monte-Carlo unit of ``arm-cmm``: 50 postures' simulated tracker data, identifiability,
   Levenberg-Marquardt, on the seed's arm.
2. One identification of 2,773 poses of a UR10 with physics (geometry, base, tool, compliance of
   the loaded joints, the kinematic prior): points from the MuJoCo twin with compliant joints
   (the size of ur10_C), our analytic Jacobian against the pybotics-style approach (scipy's
   least_squares over the same residuals with a finite-difference Jacobian).
"""

import os
import platform
import time

import numpy as np
from scipy import optimize
from threadpoolctl import threadpool_limits

from calibench.estimators.arm.calibration import loaded_joints
from calibench.estimators.arm.kinematics import parallel_axes_note
from calibench.estimators.arm.point import PointProblem
from calibench.estimators.identification.basis import identifiable_basis
from calibench.estimators.identification.solver import identify, identify_identifiable
from calibench.scenarios.arm_cmm.arms import chain_of
from calibench.scenarios.arm_cmm.scenario import tracker_problem
from calibench.sim.arm_cmm import ArmSim, ArmTruth


def seed_arm_trials(n: int = 200) -> None:
    arm = ArmSim("arm-cmm", ArmTruth())
    chain = chain_of(arm.arm)
    rng = np.random.default_rng(0)
    q = arm.random_postures(50, rng)
    t = time.perf_counter()
    for _ in range(n):
        identify_identifiable(tracker_problem(arm, chain, q, arm.encoders(q, rng), rng))
    dt = time.perf_counter() - t
    print(
        f"arm-cmm identification, 50 postures: {n / dt:.1f} trials/s on one core "
        f"({dt / n * 1000:.1f} ms each)"
    )


def ur10_physics(n: int = 2773, quiet: bool = False) -> dict:
    description = ArmSim("ur10").arm
    sim = ArmSim(description, ArmTruth(stiffness_nm_per_rad=(3e5, 2e5, 3e5, 6e4, 6e4, 6e4)))
    rng = np.random.default_rng(1)
    q = sim.random_postures(n, rng)
    y = sim.probe_mm(q) @ np.array([[0, -1, 0], [1, 0, 0], [0, 0, 1.0]]).T + [1500.0, -300.0, 200.0]
    y += rng.normal(0, 0.02, y.shape)
    chain = chain_of(description)
    joints, _ = loaded_joints(chain, q)

    def problem():
        return PointProblem(
            chain, q, y, sigma_mm=np.full_like(y, 0.02), compliance_joints=joints, prior=1.0
        )

    p = problem()
    t = time.perf_counter()
    basis = identifiable_basis(p, note=parallel_axes_note(description.parallel_pairs()))
    t_basis = time.perf_counter() - t
    t = time.perf_counter()
    ours = identify(p, basis)
    t_ours = time.perf_counter() - t

    p2 = problem()
    s0 = p2.start()
    k = basis.kept

    def residuals(x):
        step = np.zeros(len(p2.names))
        step[k] = x
        return p2.residuals(p2.update(s0, step))

    t = time.perf_counter()
    ref = optimize.least_squares(
        residuals, np.zeros(len(k)), jac="2-point", method="lm", x_scale="jac"
    )
    t_fd = time.perf_counter() - t
    cost_ours = float(np.sum(p.residuals(ours.state) ** 2))
    if not quiet:
        print(
            f"UR10, {n} poses, physics ({len(k)} parameters, compliance of joints {joints}): "
            f"basis {t_basis:.2f} s; "
            f"identification {t_ours:.2f} s with the analytic Jacobian ({ours.iterations} "
            "iterations), "
            f"{t_fd:.2f} s with finite differences ({ref.nfev} evaluations); {t_fd / t_ours:.0f}x; "
            f"cost {cost_ours:.1f} vs {2 * ref.cost:.1f}"
        )
    return {
        "n": n,
        "k": len(k),
        "ours_s": t_ours,
        "peer_s": t_fd,
        "cost_ours": cost_ours,
        "cost_peer": 2 * ref.cost,
    }


def main():
    print(f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, one BLAS thread")
    with threadpool_limits(1):
        seed_arm_trials()
        ur10_physics()


if __name__ == "__main__":
    main()
