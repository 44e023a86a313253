"""The Stewart platform's blocks: loop closure, stations, the one-step and two-step
calibrations, the held-out poses."""

from __future__ import annotations

import re

from .engine import block
from .fmt import span, table
from .runner import SEED, checks, report


@block(seconds=3, ci=True, last_digit=9)  # a gap at rounding level: any value under 1e-9 um agrees
def stewart_closure():
    """calibench run stewart --seed 0: the loop closure of MuJoCo's soft constraints."""
    closure = checks("stewart")["loop_closure_um"]["value"]
    return (
        f"MuJoCo's constraints are soft, so every pose is set from closed-form inverse kinematics "
        f"and the loop closure is measured: {closure:.0e} um at worst on seed {SEED}."
    )


@block(seconds=3, ci=True)
def stewart_stations():
    """calibench run stewart --seed 0: the stations' errors against their propagated std."""
    info = report("stewart")["info"]
    predicted = [s for station in info["station_sigma_um"] for s in station]
    return (
        f"Station errors {span(info['station_error_um'], '.0f')} um against "
        f"{span(predicted, '.0f')} um predicted per axis on seed {SEED}."
    )


@block(seconds=3, ci=True)
def stewart_one_step():
    """calibench run stewart --seed 0: the one-step calibration."""
    from calibench.scenarios.stewart.scenario import TOL_SIGMA

    info, p = report("stewart")["info"], report("stewart")["parameters"]
    ok = sum(q["ok"] for q in p)
    within = f"all {len(p)}" if ok == len(p) else f"{ok} of {len(p)}"
    return (
        f"On seed {SEED} the legs' Gauss-Newton alone is {info['pipeline_rms_error_mm']:.3f} mm "
        f"RMS off the truth; the joint adjustment has {within} within {TOL_SIGMA:g} std of it, "
        f"whitened RMS {info['whitened_rms']:.2f}."
    )


@block(seconds=3, ci=True)
def stewart_two_step():
    """calibench run stewart --seed 0: the two-step calibration's parameter error."""
    two_step = report("stewart")["info"]["compare_rms_error_mm"]["two_step"]
    return f"{two_step:.2f} mm RMS error on seed {SEED}."


@block(seconds=3, ci=True)
def stewart():
    """calibench run stewart --seed 0: held-out poses."""
    c = checks("stewart")
    n = re.match(r"(\d+)", c["pose_rms_before_um"]["note"]).group(1)
    return table(
        [f"held-out poses ({n}), from the legs' readings", "RMS error at the hinges"],
        [
            ["nominal parameters", f"{c['pose_rms_before_um']['value']:.0f} um"],
            ["one-step calibration (joint)", f"{c['pose_rms_after_um']['value']:.1f} um"],
            ["two-step calibration", f"{c['pose_rms_after_two_step_um']['value']:.0f} um"],
        ],
    )
