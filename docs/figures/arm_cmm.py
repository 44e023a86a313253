"""The seed arm's blocks: what the tracker cannot tell apart, the postures, the whitened
residual, the std's honesty under a wrong datasheet, the held-out positions."""

from __future__ import annotations

import functools

from .engine import block
from .fmt import span, table, words
from .runner import COVERAGE_PCT, SEED, checks, report

DATASHEET_FACTOR = 1.5  # the datasheet's sigma this many times the truth's, and 1 / this
DATASHEET_TRIALS = 200  # truths drawn each way (tests/scenarios/test_arm_cmm.py's count)


@block(seconds=4, ci=True)
def arm_cmm_dropped():
    """calibench run arm-cmm --seed 0: the parameters the tracker's data cannot tell apart."""
    dropped = report("arm-cmm")["info"]["dropped_tracker"]
    like = {k: v.removeprefix("moves the data as ").split(" (")[0] for k, v in dropped.items()}
    betas = sorted(k for k in like if k.startswith("dbeta"))
    rest = {k: v for k, v in like.items() if k not in betas}
    frame = [f"{k} (= {v})" for k, v in rest.items() if not v.startswith("tool_")]
    tool = sorted(k for k, v in rest.items() if v.startswith("tool_"))
    # da, dd, dalpha, dtheta, dbeta a joint
    n_joints = len(report("arm-cmm")["info"]["injected_delta"]) // 5
    parts = [", ".join(frame)] * bool(frame)
    parts += [f"{words(tool)}, which the tool absorbs"] * bool(tool)
    parts += [
        "every beta (no two of its axes are parallel, so beta repeats DH's own parameters)"
        if len(betas) == n_joints
        else words(betas)
    ] * bool(betas)
    parts[-1] = "and " + parts[-1] if len(parts) > 1 else parts[-1]
    return (
        f"Dropped for the seed's arm from tracker data ({len(dropped)}), each with what it moves "
        f"the data as: {'; '.join(parts)}."
    )


@block(seconds=4, ci=True)
def arm_cmm_postures():
    """calibench run arm-cmm --seed 0: the observability of the chosen postures."""
    from calibench.scenarios.registry import SCENARIOS

    c, n = checks("arm-cmm"), SCENARIOS["arm-cmm"].config().n_postures
    return (
        f"{c['observability_chosen']['value']:.1f} against "
        f"{c['observability_random']['value']:.1f} for {n} random postures."
    )


@block(seconds=4, ci=True)
def arm_cmm_whitened():
    """calibench run arm-cmm --seed 0: the identification's whitened residual RMS."""
    whitened = report("arm-cmm")["info"]["whitened_rms_tracker"]
    return f"On seed {SEED} the whitened residual RMS is {whitened:.2f}."


@functools.cache
def arm_coverage(factor: float, trials: int) -> tuple[float, float]:
    """The seed arm's 95 % coverage with the datasheet's sigma ``factor`` x the truth's, over
    ``trials`` truths (scenarios.arm_cmm.datasheet): as reported, and without the variance
    factor."""
    from calibench.scenarios.arm_cmm.datasheet import datasheet_coverage

    return datasheet_coverage(factor, trials)


@block(seconds=16, ci=True)
def arm_cmm_datasheet():
    """The seed arm's 95 % coverage with the datasheet's sigma 1.5x off either way, 200 trials each
    (the recipe of tests/scenarios/test_arm_cmm.py)."""
    trials, factor = DATASHEET_TRIALS, DATASHEET_FACTOR
    big, small = arm_coverage(factor, trials), arm_coverage(1 / factor, trials)
    return (
        f"The covariance carries the variance factor the residuals show, so with the datasheet "
        f"{factor:g}x too large or too small the {COVERAGE_PCT} % intervals still cover "
        f"{span([big[0], small[0]])} of the errors over {trials} trials each way ({big[1]:.3f} "
        f"and {small[1]:.3f} without the factor; a test checks the former)."
    )


@block(seconds=4, ci=True)
def arm_cmm():
    """calibench run arm-cmm --seed 0: held-out probe positions."""
    from calibench.scenarios.registry import SCENARIOS

    c, n = checks("arm-cmm"), SCENARIOS["arm-cmm"].config().n_holdout
    return table(
        [f"held-out probe positions ({n} postures), `calibench run arm-cmm`", "RMS error"],
        [
            ["nominal model", f"{c['probe_rms_before_mm']['value']:.2f} mm"],
            ["identified, chosen postures", f"{c['probe_rms_after_mm']['value']:.4f} mm"],
            ["identified, random postures", f"{c['probe_rms_after_random_mm']['value']:.4f} mm"],
            [
                "cones and bar alone (after a rigid fit: no base frame)",
                f"{c['probe_rms_after_cone_mm']['value']:.4f} mm",
            ],
        ],
    )
