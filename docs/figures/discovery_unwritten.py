"""The second concealed-effect suite's blocks (issue 36): effects no candidate writes down, under
misspecified noise, and the coverage of discover's stated standard errors."""

from __future__ import annotations

from .engine import block
from .fmt import table
from .runner import COVERAGE_PCT

COVERAGE_SEEDS = 32  # recordings per stage family and noise (the scanner's: three times as many;
# benchmarks/discover_coverage.py's default is 10: the block's figures are these)


@block(seconds=250, ci=False)
def discover_unwritten():
    """The second suite (scenarios/discover/suite_unwritten.py, as
    tests/scenarios/test_discover_unwritten.py runs it): per instrument."""
    from calibench.scenarios.discover.suite_unwritten import (
        run_unwritten,
        score_unwritten,
        unwritten_cases,
    )

    return unwritten_table(score_unwritten([run_unwritten(*case) for case in unwritten_cases()]))


def unwritten_table(scores: dict) -> str:
    """The second suite's scores per instrument (``score_unwritten``) as the block's table:
    tests/scenarios/test_discover_unwritten.py checks the README against its own run with it."""
    rows = [
        [
            scenario,
            str(s["recordings"]),
            f"{s['detection']:.0%}",
            f"{s['null_false_claim_rate']:.0%}",
            str(s["spurious_claims"]),
            f"{s['improved']:.0%}",
            f"{s['improved_fresh']:.0%} ({s['fresh_ratio']:.2f})",
        ]
        for scenario, s in scores.items()
    ]
    return table(
        [
            "instrument",
            "recordings",
            "detection (nearest named effect, where it lives)",
            "nulls with a false claim",
            "false claims beside real effects",
            "effect recordings improved on the selection's folds (in-sample)",
            "improved on a fresh recording, held out (median RMS after / before)",
        ],
        rows,
    )


@block(seconds=700, ci=False)
def discover_simulated():
    """The third suite (scenarios/discover/suite_simulated.py): mechanisms simulated, not
    written, per instrument."""
    from calibench.estimators.discovery.select import FLOOR
    from calibench.scenarios.discover.suite_simulated import (
        run_simulated,
        simulated_cases,
        simulated_scores,
    )
    from calibench.scenarios.discover.suite_unwritten import BLIND_FACTOR

    scores = simulated_scores([run_simulated(*case) for case in simulated_cases()])
    rows = [
        [
            label,
            str(s["recordings"]),
            f"{s['detection']:.0%}",
            str(s["below_floor"]),
            str(s["false_recordings"]),
            str(s["blind_verdicts"]),
            f"{s['improved_fresh']:.0%} ({s['fresh_ratio']:.2f})",
        ]
        for label, s in scores.items()
    ]
    return table(
        [
            "instrument",
            "recordings",
            "detection (nearest named effect, where it lives, of those within reach)",
            f"beyond reach (removed whole, it would cut the held-out RMS by < {FLOOR:.0%})",
            "recordings with a false claim",
            f'"nothing missing" above {BLIND_FACTOR} x the true noise',
            "improved on a fresh recording, held out (median RMS after / before)",
        ],
        rows,
    )


MECHANISM_SEEDS = 40  # recordings per case (benchmarks/discover_mechanism_coverage.py's default)


@block(seconds=1500, ci=False)
def discover_mechanism_coverage():
    """The stated errors of issue 61's mechanisms against their truths, under gaussian and the
    third suite's noises in turn (scenarios/discover/mechanism_coverage.py, as
    benchmarks/discover_mechanism_coverage.py runs it)."""
    import os

    import numpy as np

    from calibench.scenarios.discover.mechanism_coverage import mechanism_coverage

    rows = []
    for c in mechanism_coverage(MECHANISM_SEEDS, workers=len(os.sched_getaffinity(0))):
        z_rms = float(np.sqrt(np.mean(c.z**2))) if len(c.z) else float("nan")
        rows.append(
            [
                c.kind,
                c.parameter,
                str(c.recordings),
                str(len(c.z)),
                f"{c.coverage:.2f}",
                f"{z_rms:.2f}",
            ]
        )
    return table(
        [
            "case",
            "parameter",
            "recordings",
            "found",
            f"coverage of the stated {COVERAGE_PCT} % intervals",
            "RMS of (estimate - truth) / stated std",
        ],
        rows,
    )


@block(seconds=3100, ci=False)
def discover_coverage():
    """discover's stated intervals against the truth, under each reading noise
    (scenarios/discover/stated_errors.py, as benchmarks/discover_coverage.py runs it)."""
    import os

    import numpy as np

    from calibench.scenarios.discover.stated_errors import coverage_study

    rows = []
    for c in coverage_study(COVERAGE_SEEDS, workers=os.cpu_count() or 1):
        z_rms = float(np.sqrt(np.mean(c.z**2))) if len(c.z) else float("nan")
        rows.append(
            [
                c.scenario,
                c.noise,
                str(c.recordings),
                str(len(c.z)),
                f"{c.coverage:.2f}",
                f"{z_rms:.2f}",
                str(c.missed),
            ]
        )
    return table(
        [
            "family",
            "reading noise",
            "recordings",
            "parameters",
            f"coverage of the stated {COVERAGE_PCT} % intervals",
            "RMS of (estimate - truth) / stated std",
            "effects missed",
        ],
        rows,
    )


# the recordings discover-left shows: the belt stage's unwritten presliding and lagged scale
PRESLIDING_SEED = 1
LAGGED_SEED = 0


@block(seconds=15, ci=True, rel=0.02)
def discover_left():
    """What discovery leaves unexplained, and says so: the belt stage's unwritten `presliding`
    recording of seed 1 (its figure, docs/discover_unexplained.png) and the `lagged_thermal`
    one of seed 0 with the lag left out of the candidates (as before issue 61)."""
    from calibench.estimators.discovery import lag
    from calibench.scenarios.discover.figure import write_figure
    from calibench.scenarios.stages.discovery import discover_stage
    from calibench.sim.concealed import stage_recording

    from .engine import ROOT

    def said(out: dict) -> str:
        u, f = out["unexplained"], out["noise_floor"]
        where = f"follows {u['driver']}" if u and u["driver"] else "follows no driver searched"
        return (
            f"{1000 * out['fit']['cv_rms_final']:.2f} um held out against a "
            f"{1000 * f['sigma_mm']:.2f} um noise floor ({f['from']}; the residual correlated "
            f"{f['lag1_time']:.2f} from one reading to the next): "
            + (f"`unexplained`, {where}" if u else "explained")
        )

    rec, _ = stage_recording("belt-stage", "presliding", PRESLIDING_SEED)
    out, fig = discover_stage("belt-stage", rec, PRESLIDING_SEED)
    write_figure(ROOT / "docs" / "discover_unexplained.png", out, fig)
    lines = [
        f"- belt-stage, `presliding` (seed {PRESLIDING_SEED}, [figure](discover_unexplained.png)): "
        "found "
        + ", ".join(f"`{e['name']}` ({e['axis']})" for e in out["effects"])
        + "; "
        + said(out)
        + "."
    ]
    real = lag.LagSearch.applies
    lag.LagSearch.applies = lambda self, drivers: False  # the library before the lag
    try:
        rec, _ = stage_recording("belt-stage", "lagged_thermal", LAGGED_SEED)
        out, _ = discover_stage("belt-stage", rec, LAGGED_SEED)
    finally:
        lag.LagSearch.applies = real
    lines.append(
        f"- belt-stage, `lagged_thermal` (seed {LAGGED_SEED}) without the lag among the "
        "candidates: found "
        + ", ".join(f"`{e['name']}` ({e['axis']})" for e in out["effects"])
        + "; "
        + said(out)
        + " (the repeatability from repeats hours apart: "
        + f"{1000 * max(v['repeatability_mm'] for v in out['noise'].values()):.2f} um)."
    )
    return "\n".join(lines)
