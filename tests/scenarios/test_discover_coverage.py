"""The coverage study shared over processes gives the figures of one process, recording for
recording (each recording seeded), so the README's block can use every core."""

import numpy as np

from calibench.scenarios.discover import stated_errors as coverage


def test_the_coverage_study_is_the_same_over_processes(monkeypatch):
    # one stage family and the scanner, one noise: the smallest study that crosses both paths
    monkeypatch.setattr(
        coverage, "CASES", (("belt-stage", "combined", 1), ("probe-scanner", "runout", 2))
    )
    here = coverage.coverage_study(1, ("t3",))
    spread = coverage.coverage_study(1, ("t3",), workers=2)
    assert [(c.scenario, c.noise, c.recordings, c.missed) for c in here] == [
        (c.scenario, c.noise, c.recordings, c.missed) for c in spread
    ]
    assert [("belt-stage", 1), ("probe-scanner", 2)] == [(c.scenario, c.recordings) for c in here]
    for a, b in zip(here, spread):
        assert len(a.z) > 0
        np.testing.assert_array_equal(a.z, b.z)
