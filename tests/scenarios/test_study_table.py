"""What a study's console table and figure tell a reader: the coverage band the trials allow,
and what each column means."""

import numpy as np

from calibench.scenarios.study.figure import coverage_band
from calibench.scenarios.study.summary import TABLE_NOTE, summary_table


def test_the_coverage_band_is_the_binomial_scatter_of_an_honest_std():
    """Coverage of 95 % intervals over n trials is Binomial(n, 0.95) / n: its 2-sigma band.
    Simulated: 20,000 studies of 400 honest trials land inside it about 95 % of the time."""
    lo, hi = coverage_band(400)
    assert abs(lo - (0.95 - 2 * np.sqrt(0.95 * 0.05 / 400))) < 1e-12 and hi > 0.95
    rng = np.random.default_rng(0)
    cover = rng.binomial(400, 0.95, 20_000) / 400
    inside = np.mean((cover >= lo) & (cover <= hi))
    assert 0.93 < inside < 0.98
    assert coverage_band(1)[1] == 1.0  # one trial: the band is clipped at certainty


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
