"""Bad-input cases, `uncertainty`: studies it must refuse before any trial.

See tests/test_bad_input.py, which runs every case.
"""

from __future__ import annotations

_UNC = ["uncertainty", "arm-cmm", "--out", "{d}/o"]

# (id, files to write {name: text or bytes or callable(path)}, argv with {d} for the case folder,
#  expected exit status, a fragment the message must contain)
CASES = [
    # an instrument without a task: tests/scenarios/test_uncertainty_study.py (each has one now)
    (
        "uncertainty-unknown-scenario",
        {},
        ["uncertainty", "hexapod", "--out", "{d}/o"],
        2,
        "unknown scenario 'hexapod'",
    ),
    ("uncertainty-tolerance-zero", {}, [*_UNC, "--tolerance", "0"], 2, "a positive number"),
    ("uncertainty-tolerance-nan", {}, [*_UNC, "--tolerance", "nan"], 2, "a positive number"),
    ("uncertainty-tolerance-word", {}, [*_UNC, "--tolerance", "tight"], 2, "not a number"),
    ("uncertainty-trials-max-zero", {}, [*_UNC, "--trials-max", "0"], 2, "trials-max"),
    (
        "uncertainty-trials-max-below-two-batches",
        {},
        [*_UNC, "--trials-max", "200"],
        2,
        "at least 400 (two batches)",
    ),
    (
        "uncertainty-config-of-another-scenario",
        {"c.toml": "[stewart]\nn_poses = 40\n"},
        [*_UNC, "--config", "{d}/c.toml"],
        2,
        "takes only",
    ),
]
