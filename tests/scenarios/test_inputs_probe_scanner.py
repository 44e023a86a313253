"""Issue 62, item 9: `run probe-scanner` failed its own check for seeds 1, 2, 2^32 and 2^63-1.

The estimator was right, the tolerance wrong: on one turn the paper's four-minima method (m =
50) scatters 0.31 mm in d (bias +0.12 mm: the quadratic's bend, +0.08 mm without noise), and
the check asked every turn to be within the 0.5 mm requirement, 1.6 of its sigma; alpha0, whose
error is d's through asin(d / a) (correlation -0.9999), had a tolerance of requirement / a that
left out the 1 / cos of that asin besides. Over seeds 1-200, 25 failed d and 35 alpha0. The
paper's parameters are now judged, as the least squares' are, by TOL_SIGMA of their 1-sigma:
the method's scatter over the run's own fresh turns.
"""

import numpy as np
import pytest

from calibench.scenarios.probe_scanner import scenario as probe_scanner
from calibench.scenarios.registry import SCENARIOS


@pytest.mark.parametrize("seed", [1, 2, 2**32, 2**63 - 1])
def test_the_demo_passes_for_the_seeds_that_failed(seed):
    s = SCENARIOS["probe-scanner"]
    report = s.execute(s.config(), seed, "analytic", None, False)
    bad = [p.name for p in report.parameters if not p.ok] + [
        c.name for c in report.checks if not c.ok
    ]
    assert report.ok, bad
    paper = {p.name: p for p in report.parameters if p.name.endswith("_paper")}
    assert set(paper) == {"d_paper", "dL_paper", "alpha0_paper"}
    for p in paper.values():  # a stated 1-sigma, and the tolerance TOL_SIGMA of it
        assert p.std is not None and p.std > 0
        assert p.tolerance == pytest.approx(probe_scanner.TOL_SIGMA * p.std)
    # the method's scatter as measured over 200 seeds (d 0.31 mm, alpha0 14.9 mrad), within
    # what 20 turns can tell
    assert 0.15 < paper["d_paper"].std < 0.5
    assert 7 < paper["alpha0_paper"].std < 25


def test_the_spread_is_the_scatter_over_turns():
    """paper_spread is the ddof-1 scatter of the method's own estimates, alpha0 on one branch."""
    from calibench.sim.probe_scanner import ProbeScannerSim

    c = probe_scanner.ProbeScannerConfig()
    sim = ProbeScannerSim(c.geometry, c.truth)
    rng = np.random.default_rng(3)
    turns = [sim.scan("plate", rng)[0] for _ in range(6)]
    spread = probe_scanner.paper_spread(turns, 50, 22.5, c.nominal.alpha0_rad)
    fits = [
        probe_scanner.calibrate_paper(t.theta_rad, t.rho_mm, 50, 22.5, c.nominal.alpha0_rad)
        for t in turns
    ]
    assert spread["d_mm"] == pytest.approx(np.std([f.d_mm for f in fits], ddof=1))
    assert spread["alpha0_rad"] == pytest.approx(np.std([f.alpha0_rad for f in fits], ddof=1))
