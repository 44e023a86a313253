"""The second concealed-effect suite (issue 36): effects no candidate writes down (presliding
friction, a scale that warms behind a lag, a rail joined with a step, a Stewart leg whose hinges
stick and slip, a plate's wall that gives where it is thin), each under noise that breaks the
estimators' assumption (Student t with 3 degrees of freedom, a slow drift, gross outliers),
through discover blind and scored against the sealed manifests afterwards
(scenarios/discover/suite_unwritten.py)."""

from calibench.scenarios.discover.suite_unwritten import (
    UNWRITTEN_SUITE,
    run_unwritten,
    score_unwritten,
    unwritten_table,
)
from calibench.sim.concealed.noise import MISSPECIFIED


def test_unwritten_effects_under_misspecified_noise():
    results = [run_unwritten(*case) for case in UNWRITTEN_SUITE]
    print(unwritten_table(results))
    scores = score_unwritten(results)
    print(scores)
    assert {r.noise for r in results} == set(MISSPECIFIED)
    assert set(scores) == {"belt-stage", "vision-stage", "probe-scanner", "stewart"}
    for scenario, s in scores.items():
        assert s["detection"] >= 0.9, (scenario, s)
        assert s["null_false_claim_rate"] <= 0.05, (scenario, s)
        assert s["spurious_claims"] <= 1, (scenario, s)
        assert s["improved"] == 1.0, (scenario, s)
