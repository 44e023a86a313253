"""Throughput of the adaptive Monte Carlo procedure (JCGM 101 7.9) on this machine:
``python benchmarks/uncertainty_adaptive.py``.

A linear task y = J x of Q output quantities (a grid's points) from P = 12 Gaussian parameters,
run to n_dig = 2 at delta/5 (the tolerance that validates the GUM framework, JCGM 101 8.2), with
the probabilistically symmetric and the shortest interval, within a budget of about 5 x 10^8
model values (a wide grid stops at its budget: all its quantities must meet the tolerance). It
prints the batches, the trials and the model values per second: the model here is one matrix
product, so the rate is the procedure's own cost (a batch's selection or sort of its M x Q values)
more than the model's.
"""

import os
import platform
import time

import numpy as np

from calibench.estimators.uncertainty.adaptive import adaptive, batch_rng

P = 12


def run(q: int, shortest: bool) -> None:
    jac = np.random.default_rng(0).normal(size=(q, P))

    def draw(index, m):
        return batch_rng(1, index).standard_normal((m, P)) @ jac.T

    t = time.perf_counter()
    # a budget of some 5 x 10^8 values: Q = 1 runs to its tolerance, a wide grid shows its rate
    budget = min(10**7, 5 * 10**8 // q)
    res = adaptive(draw, n_dig=2, delta_scale=0.2, shortest=shortest, trials_max=budget)
    dt = time.perf_counter() - t
    interval = "shortest" if shortest else "symmetric"
    print(
        f"Q={q:5d} {interval:9s} {res.batches.count:4d} batches {res.trials:9d} trials "
        f"{dt:7.2f} s  {res.trials / dt:11.3g} trials/s  {res.trials * q / dt:11.3g} values/s"
        f"  ({res.status})"
    )


def main() -> None:
    print(
        f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
        f"python {platform.python_version()}, numpy {np.__version__}"
    )
    for q in (1, 100, 1000):
        for shortest in (False, True):
            run(q, shortest)


if __name__ == "__main__":
    main()
