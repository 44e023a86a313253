"""The concealed-effect suite (issues 8 and 13): 41 blinded recordings through discover (stages, the
seed's arm and a UR10 with compliance made by MuJoCo's physics),
scored against their sealed manifests only afterwards (see scenarios/discover_suite.py)."""

from calibench.scenarios.discover_suite import SUITE, run_case, score, table


def test_concealed_effect_suite():
    results = [run_case(*case) for case in SUITE]
    s = score(results)
    print(table(results))
    print(s)
    assert s["recordings"] >= 40
    assert s["detection"] >= 0.90
    assert s["null_false_claim_rate"] <= 0.05
    assert s["params_within_limit"] == 1.0, s["worst_param"]
    assert s["n_dominated"] >= 8 and s["ratios_ok"] == 1.0, s["worst_ratio"]
    assert s["spurious_claims"] <= 2
