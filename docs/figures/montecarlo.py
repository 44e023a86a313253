"""The Monte-Carlo studies' blocks: coverage under a wrong datasheet, the studies' coverage and
efficiency, the twins with their physics on, and the band an honest coverage scatters in."""

from __future__ import annotations

import functools

from .engine import block
from .fmt import mean, sci, span, table
from .runner import COVERAGE_PCT, SEED, scratch, study

DATASHEET_FACTOR = 1.5  # benchmarks/datasheet_coverage.py: the datasheet right, this x and 1 / this
DATASHEET_TRIALS = {"arm-cmm": 1000, "stewart": 200}  # that benchmark's default trial counts
# calibench montecarlo SCENARIO --trials N, and what its summary's parameters are
STUDIES = (
    ("arm-cmm", 1000, "parameters with a reference"),
    ("stewart", 1000, "leg parameters"),
    ("belt-stage", 200, "parameters"),
)
BAND_TRIALS = (1000, 200)  # the trial counts whose coverage band coverage-bands quotes
INTERVAL_PCT = 95  # summarise's binomial band and chi-square interval: 2.5 % to 97.5 %

# The physics each twin can carry, as a run's config switches it on (README, "Physics in the
# twins"): (scenario, arm, trials, what, config table, the check to show, its scale to um).
BELT_EA_N, BELT_FRICTION_N = 35e3, 4.0  # both belts' stiffness and the carriage's dry friction
LEG_COMPLIANCE_UM_PER_N, PAYLOAD_N = 0.03, 1000.0  # every leg's, under the platform's payload
UR10_STIFFNESS_NM_PER_RAD = (3e5, 2e5, 3e5, 6e4, 6e4, 6e4)  # joints 1 to 6
PHYSICS = (
    (
        "belt-stage",
        None,
        20,
        f"both belts elastic (EA {BELT_EA_N / 1e3:g} kN) against {BELT_FRICTION_N:g} N of "
        "carriage friction",
        {
            "truth": {
                "belt_x": {"ea_n": BELT_EA_N, "friction_n": BELT_FRICTION_N},
                "belt_y": {"ea_n": BELT_EA_N, "friction_n": BELT_FRICTION_N},
            }
        },
        "check_rms_after_mm",
        1000,
    ),
    (
        "stewart",
        None,
        100,
        f"every leg {LEG_COMPLIANCE_UM_PER_N:g} um/N under MuJoCo's statics, {PAYLOAD_N:g} N "
        "payload",
        {
            "truth": {
                "leg_compliance_um_per_n": [LEG_COMPLIANCE_UM_PER_N] * 6,
                "payload_n": PAYLOAD_N,
            }
        },
        "pose_rms_after_um",
        1,
    ),
    (
        "arm-cmm",
        "ur10",
        200,
        f"a UR10, joints {span(range(1, len(UR10_STIFFNESS_NM_PER_RAD) + 1), 'd')} of "
        f"{', '.join(map(sci, UR10_STIFFNESS_NM_PER_RAD))} N m/rad under MuJoCo's gravity",
        {"truth": {"stiffness_nm_per_rad": list(UR10_STIFFNESS_NM_PER_RAD)}},
        None,
        1,
    ),
)


@block(seconds=55, ci=True, rel=0.01)
def datasheet_coverage():
    """benchmarks/datasheet_coverage.py's studies: 1000 arm and 200 Stewart trials with the
    datasheet right, 1.5x too large and 1.5x too small."""
    from calibench.scenarios.study.honesty import covered, outside_band, pooled_coverage

    out = {}
    for scenario, n in DATASHEET_TRIALS.items():
        pooled, outside = [], []
        for factor in (1.0, DATASHEET_FACTOR, 1 / DATASHEET_FACTOR):
            s = study(scenario, n, factor)
            pooled.append(pooled_coverage(s))
            outside.append(outside_band(s))
        ps = covered(s)
        out[scenario] = (n, pooled, outside, len(ps), ps[0]["coverage_95_expected"])
    (na, pa, oa, ka, ba), (ns, pst, ost, ks, bs) = out["arm-cmm"], out["stewart"]
    same = all(span(x) == format(x[0], ".3f") for x in (pa, pst))
    why = (
        ", the same in all three, since a common factor on every sigma changes the weights of "
        "nothing and the variance factor restores the std"
        if same
        else " over the three datasheets"
    )
    f = f"{DATASHEET_FACTOR:g}x"
    return (
        f"`benchmarks/datasheet_coverage.py` runs {na} arm and {ns} Stewart trials with the "
        f"datasheet's sigma right, {f} too large and {f} too small: pooled coverage "
        f"{span(pa, '.3f', ' to ')} (arm, band {ba[0]:.3f}-{ba[1]:.3f}) and "
        f"{span(pst, '.3f', ' to ')} (Stewart, band {bs[0]:.2f}-{bs[1]:.2f}){why}; "
        f"{span(oa, 'd', ' to ')} of {ka} and {span(ost, 'd', ' to ')} of {ks} parameters' own "
        f"coverage outside their binomial band."
    )


@block(seconds=75, ci=True, rel=0.01)
def montecarlo_studies():
    """calibench montecarlo arm-cmm --trials 1000, stewart --trials 1000, belt-stage --trials 200
    (seed 0, analytic)."""
    from calibench.scenarios.study.honesty import covered

    rows = []
    # the arm's parameters are those with an independent reference (the frames and the errors that
    # absorb others are judged by held-out positions, not by coverage)
    for scenario, n, what in STUDIES:
        s = study(scenario, n)
        cov = [p["coverage_95"] for p in covered(s)]
        eff = [p["efficiency"] for p in s["parameters"] if p.get("efficiency") is not None]
        analytic = ", analytic" if scenario == "belt-stage" else ""
        rows.append(
            [
                f"{scenario}{analytic} ({len(s['parameters'])} {what})",
                f"{s['trials']}",
                f"{span(cov)} (mean {mean(cov):.3f})",
                f"{span(eff, '.2f')} (mean {mean(eff):.2f})" if eff else "(no bound computed)",
            ]
        )
    return table(["study", "trials", "coverage_95", "efficiency (CRLB var / MC var)"], rows)


@functools.cache
def physics_study(scenario: str, trials: int, physics: bool) -> dict:
    """A Monte-Carlo study (seed 0, analytic) of the rigid twin or of the one with PHYSICS on."""
    from calibench.scenarios.study.montecarlo import run_study

    arm, table_ = next((a, t) for s, a, n, _, t, *_ in PHYSICS if s == scenario)
    out = scratch() / "physics" / f"{scenario}-{trials}-{physics}"
    return run_study(
        scenario,
        trials,
        SEED,
        "analytic",
        out,
        progress=False,
        table=table_ if physics else None,
        arm=arm,
    )


@block(seconds=50, ci=True)
def physics_studies():
    """calibench montecarlo with each twin's physics off and on (PHYSICS): what a geometry-only
    calibration does on a machine that has it."""
    from calibench.scenarios.study.honesty import (
        covered,
        median_std_ratio,
        outside_band,
        pooled_coverage,
        worst_bias,
    )

    rows = []
    for scenario, _, n, what, _, check, scale in PHYSICS:
        s0, s1 = physics_study(scenario, n, False), physics_study(scenario, n, True)
        k0, k1 = (
            next((c for c in s.get("checks", []) if c["name"] == check), None) for s in (s0, s1)
        )
        name, bias = worst_bias(s1)
        checked = (
            "-"
            if k0 is None
            else f"{scale * k0['median']:.1f} -> {scale * k1['median']:.1f} um ({check})"
        )
        rows.append(
            [
                f"{scenario}: {what}",
                f"{n}",
                f"{pooled_coverage(s0):.3f} -> {pooled_coverage(s1):.3f}",
                f"{outside_band(s0)} -> {outside_band(s1)} of {len(covered(s0))}",
                f"{name}: {bias:.1f} std",
                f"x {median_std_ratio(s0, s1):.1f}",
                checked,
            ]
        )
    return table(
        [
            "study (rigid twin -> with physics)",
            "trials",
            "pooled coverage_95",
            "parameters outside their band",
            "worst bias",
            "reported std (median)",
            "median check",
        ],
        rows,
    )


@block(seconds=1, ci=True)
def coverage_bands():
    """scenarios.montecarlo.summarise's band for an honest 95 % coverage at 1000 and 200 trials."""
    from calibench.scenarios.study.summary import summarise

    def band(n):  # the band summary.json writes beside every coverage, for n trials
        rows = [
            {"trial": i, "ok": True, "p.estimate": 0.0, "p.truth": 0.0, "p.std": 1.0, "p.unit": ""}
            for i in range(n)
        ]
        return summarise("any", rows, 0.0)["parameters"][0]["coverage_95_expected"]

    (n1, b1), (n2, b2) = ((n, band(n)) for n in BAND_TRIALS)
    return (
        f"With N trials an honest {COVERAGE_PCT} % coverage itself scatters: its {INTERVAL_PCT} % "
        f"band is {b1[0]:.3f}-{b1[1]:.3f} at {n1} trials and {b2[0]:.2f}-{b2[1]:.2f} at {n2}, "
        f"and `summary.json` gives that band (`coverage_95_expected`) beside every coverage and "
        f"a chi-square {INTERVAL_PCT} % interval beside every efficiency, so a reader can tell "
        f"scatter from a dishonest std."
    )
