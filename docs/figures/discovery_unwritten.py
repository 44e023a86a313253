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
