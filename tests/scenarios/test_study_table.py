"""What a study's console table and figure tell a reader: the coverage band the trials allow,
and what each column means."""

import numpy as np

from calibench.scenarios.study.figure import GREEN, RED, write_study_figure
from calibench.scenarios.study.summary import (
    TABLE_NOTE,
    coverage_band,
    in_band,
    summarise,
    summary_table,
)


def test_the_coverage_band_is_the_binomial_scatter_of_an_honest_std():
    """Coverage of 95 % intervals over n trials is Binomial(n, 0.95) / n: the band between its
    2.5 % and 97.5 % quantiles. Simulated: 20,000 studies of 400 honest trials land inside it
    at least 95 % of the time (a discrete band holds a little more)."""
    lo, hi = coverage_band(400)
    assert (lo * 400, hi * 400) == (371, 388)  # scipy.stats.binom.ppf([0.025, 0.975], 400, 0.95)
    rng = np.random.default_rng(0)
    cover = rng.binomial(400, 0.95, 20_000) / 400
    inside = np.mean([in_band(c, (lo, hi)) for c in cover])
    assert 0.95 <= inside < 0.98
    assert coverage_band(1)[1] == 1.0  # one trial: the band ends at certainty


def test_a_coverage_on_the_band_s_edge_is_inside_in_the_summary_and_the_figure(tmp_path):
    """20 trials, 17 covered: a coverage of 0.85, the band's lower edge. summary.json counts it
    inside, and study.png draws its bar green under the band's label (one rule for both); 16
    covered (0.80) is outside in both, its bar red."""
    import cv2

    for covered, inside in ((17, True), (16, False)):
        rows = [
            {"trial": i, "ok": True, "p.truth": 0.0, "p.estimate": 1.0 if i < covered else 3.0}
            | {"p.std": 1.0, "p.unit": "mm"}
            for i in range(20)
        ]
        p = summarise("any", rows, 0.0)["parameters"][0]
        assert p["coverage_95"] == covered / 20
        assert p["coverage_95_expected"] == [0.85, 1.0]
        assert in_band(p["coverage_95"], p["coverage_95_expected"]) == inside
        write_study_figure(tmp_path / "study.png", rows, summarise("any", rows, 0.0))
        img = cv2.imread(str(tmp_path / "study.png"))[:, 700:]  # the coverage panel
        green, red = ((img == colour).all(axis=2).sum() for colour in (GREEN, RED))
        assert (green > 100, red > 100) == (inside, not inside)


def test_the_table_says_what_coverage_and_efficiency_mean():
    s = {
        "parameters": [
            {
                "name": "fx",
                "unit": "px",
                "bias": 0.01,
                "rmse": 0.1,
                "mean_std": 0.1,
                "coverage_95": 0.95,
                "efficiency": 0.98,
                "efficiency_ci95": [0.9, 1.1],
            }
        ]
    }
    table = summary_table(s)
    assert table.endswith(TABLE_NOTE)
    assert "Cramer-Rao" in TABLE_NOTE and "1.96 reported std" in TABLE_NOTE
