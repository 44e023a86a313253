"""Speed work must not change results: two Monte-Carlo trials of every scenario (analytic
fidelity, study seed 0) against the table stored in ``golden_trials.json``.

A trial is deterministic from its seed, so on one machine the figures agree bit for bit; the
tolerance (1e-7 relative) only absorbs another machine's BLAS rounding, far below any figure the
bench reports. A deliberate change of an estimator's results regenerates the table, in the same
commit, with::

    MUJOCO_GL=egl python -m tests.scenarios.test_golden_trials --write
"""

import json
import sys
from pathlib import Path

import numpy as np
import pytest

from calibench.scenarios.registry import NAMES
from calibench.scenarios.study.trials import run_trial

GOLDEN = Path(__file__).with_name("golden_trials.json")
TRIALS = (0, 1)


def _table(scenario: str) -> dict:
    """{trial: {column: value}} of the numeric columns (estimate, std, truth) of two trials."""
    out = {}
    for i in TRIALS:
        row = run_trial(scenario, 0, i, "analytic")
        assert row["ok"], row.get("error")
        out[str(i)] = {
            k: v
            for k, v in row.items()
            if k.endswith((".estimate", ".std", ".truth")) and v is not None
        }
    return out


@pytest.mark.parametrize("scenario", NAMES)
def test_trials_are_what_they_were(scenario):
    golden = json.loads(GOLDEN.read_text())[scenario]
    now = _table(scenario)
    assert now.keys() == golden.keys()
    for i in golden:
        assert now[i].keys() == golden[i].keys(), f"trial {i}: other parameters"
        names = sorted(golden[i])
        np.testing.assert_allclose(
            [now[i][k] for k in names],
            [golden[i][k] for k in names],
            rtol=1e-7,
            atol=1e-12,
            err_msg=f"{scenario} trial {i}",
        )


if __name__ == "__main__" and "--write" in sys.argv:
    GOLDEN.write_text(json.dumps({s: _table(s) for s in NAMES}, indent=1, sort_keys=True) + "\n")
    print(f"-> {GOLDEN}")
