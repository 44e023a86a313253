"""Bad-input cases, `acceptance`: tests and limits it must refuse before any work.

See tests/test_bad_input.py, which runs every case.
"""

from __future__ import annotations

_ACC = ["acceptance", "arm-cmm", "--test", "iso10360-12", "--out", "{d}/o"]

# (id, files to write {name: text or bytes or callable(path)}, argv with {d} for the case folder,
#  expected exit status, a fragment the message must contain)
CASES = [
    (
        "acceptance-test-of-another-instrument",
        {},
        ["acceptance", "stewart", "--test", "iso9283", "--out", "{d}/o"],
        2,
        "does not apply to stewart",
    ),
    (
        "acceptance-unknown-scenario",
        {},
        ["acceptance", "hexapod", "--test", "iso9283", "--out", "{d}/o"],
        2,
        "hexapod",
    ),
    ("acceptance-unknown-test", {}, ["acceptance", "arm-cmm", "--test", "iso1"], 2, "iso1"),
    (
        "acceptance-stage-test-on-the-arm",
        {},
        ["acceptance", "arm-cmm", "--test", "iso230-2", "--out", "{d}/o"],
        2,
        "its tests: iso9283, iso10360-12",
    ),
    (
        "acceptance-mpe-of-a-figure-it-does-not-report",
        {"c.toml": "[acceptance.mpe]\nAP_mm = 0.1\n"},
        [*_ACC, "--config", "{d}/c.toml"],
        2,
        "does not report",
    ),
    (
        "acceptance-mpe-below-zero",
        {"c.toml": "[acceptance.mpe]\nE_UNI_um = -3\n"},
        [*_ACC, "--config", "{d}/c.toml"],
        2,
        "a positive number",
    ),
    (
        "acceptance-mpe-not-a-table",
        {"c.toml": "[acceptance]\nmpe = 3\n"},
        [*_ACC, "--config", "{d}/c.toml"],
        2,
        "must be a table",
    ),
    (
        "acceptance-config-of-another-scenario",
        {"c.toml": "[stewart]\nn_poses = 40\n"},
        [*_ACC, "--config", "{d}/c.toml"],
        2,
        "takes only",
    ),
    (
        "acceptance-recording-for-a-test-without-one",
        {},
        [*_ACC, "--recording", "data/ur10_landgraf/ur10_D.csv"],
        2,
        "--recording: a real arm's RP",
    ),
    (
        "acceptance-recording-without-repeats",
        {
            "r.csv": "q1_deg,q2_deg,q3_deg,q4_deg,q5_deg,q6_deg,x_mm,y_mm,z_mm\n"
            "0,10,20,30,40,50,1,2,3\n5,15,25,35,45,55,4,5,6\n"
        },
        [
            "acceptance",
            "arm-cmm",
            "--test",
            "iso9283",
            "--recording",
            "{d}/r.csv",
            "--out",
            "{d}/o",
        ],
        2,
        "no posture is visited twice",
    ),
]
