"""What the arm-cmm scenario judges its identification against: the injected errors as the
identification's kept parameters should find them (:func:`reference_values`, by the known
relations between dependent parameters, never by a fit), and each kept parameter with its
reference, in its unit.
"""

from __future__ import annotations

import numpy as np

from calibench.estimators.arm.kinematics import param_names, parameter_scales
from calibench.estimators.identification.solver import Identification
from calibench.scenarios.report import Parameter

TOL_SIGMA = 5.0


def reference_values(arm, delta: np.ndarray, kept: list[str], partners: dict) -> dict[str, float]:
    """The injected errors ``delta`` (5 N + 3,) as the identification's ``kept`` parameters
    should find them, by the known relations between dependent parameters, never by a fit.

    A kept kinematic error is its injected value when no dropped parameter's injected error
    leans on it (``partners``, the basis's first-order relations, only decide which; the values
    come from ``delta`` alone). Along a run of consecutive parallel axes only the sum of the runs' d
    moves the data (their common normals slide along parallel axes), so the one d the basis keeps
    carries the sum. Parameters that absorb other errors by a relation that runs through the chain
    (the tracker frame, the tool point, a wrist angle seen through the tool's lever) have no entry:
    held-out positions from MuJoCo judge them instead.
    """
    inj = dict(zip(param_names(arm.n_joints), map(float, delta)))
    runs: list[list[int]] = []
    for i, k in arm.parallel_pairs():
        if runs and runs[-1][-1] == i:
            runs[-1].append(k)
        else:
            runs.append([i, k])
    in_run = {f"dd{j}": run for run in runs for j in run}
    # a dropped error moves a kept one by coefficient x its size; below 1e-3 of the kept one's
    # typical size (0.1 um, 1 nrad) that is nothing a test could see
    leaned_on = set()
    for d, coefs in partners.items():
        if d in in_run or inj.get(d, 0.0) == 0.0:
            continue
        size = abs(inj[d]) / parameter_scales([d])[0]
        leaned_on |= {k for k, c in coefs.items() if abs(c) * size > 1e-3}
    ref = {}
    for name in kept:
        if name not in inj or name.startswith("tool_") or name in leaned_on:
            continue
        if name in in_run:
            ds = [f"dd{j}" for j in in_run[name]]
            if sum(d in kept for d in ds) != 1:
                continue
            ref[name] = sum(inj[d] for d in ds)
        else:
            ref[name] = inj[name]
    return ref


def is_angle(name: str) -> bool:
    """Whether a tracker problem's parameter is an angle (rad; reported in urad), not a length."""
    return name.startswith(("dalpha", "dtheta", "dbeta", "tracker_r"))


def tracker_parameters(
    names: tuple[str, ...], ident: Identification, reference: dict[str, float]
) -> tuple[list[Parameter], dict[str, dict]]:
    """Each kept parameter (urad or mm) against its independent reference
    (:func:`reference_values`), within :data:`TOL_SIGMA` std; and those with no such reference
    (the frames, errors that absorb others through the chain), which the held-out positions
    judge instead, by name."""
    parameters, by_holdout = [], {}
    for name in (names[k] for k in ident.basis.kept):
        angle = is_angle(name)
        f = 1e6 if angle else 1.0
        if name not in reference:
            by_holdout[name] = {
                "unit": "urad" if angle else "mm",
                "estimate": ident.estimate[name] * f,
                "std": ident.std[name] * f,
            }
            continue
        parameters.append(
            Parameter(
                name,
                "urad" if angle else "mm",
                reference[name] * f,
                ident.estimate[name] * f,
                ident.std[name] * f,
                TOL_SIGMA * ident.std[name] * f,
            )
        )
    return parameters, by_holdout
