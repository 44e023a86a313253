"""Bad-input cases, what a first probe of the arm commands found (stop 29).

See tests/test_bad_input.py, which runs every case.
"""

from __future__ import annotations

import json

import numpy as np

from tests.bad_input.files import (
    ARM_TOML,
    arm_csv,
    arm_csv_with,
    arm_rows,
)

# (id, files to write {name: text or bytes or callable(path)}, argv with {d} for the case folder,
#  expected exit status, a fragment the message must contain)
CASES = [
    # what a first probe of the arm commands found (stop 29)
    (
        "arm-file-empty",
        {"a.toml": "", "r.csv": lambda p: p.write_text(arm_csv(*arm_rows(n_joints=2)))},
        ["fit", "arm-cmm", "{d}/r.csv", "--arm", "{d}/a.toml"],
        2,
        "is empty",
    ),
    (
        "arm-file-no-length",
        {
            "a.toml": ARM_TOML.replace("300.0", "0.0")
            .replace("100.0", "0.0")
            .replace("250.0", "0.0"),
            "r.csv": lambda p: p.write_text(arm_csv(*arm_rows(n_joints=2))),
        },
        ["fit", "arm-cmm", "{d}/r.csv", "--arm", "{d}/a.toml"],
        2,
        "no length",
    ),
    (
        "arm-file-huge-tool",
        {
            "a.toml": ARM_TOML + "[tool]\noffset_mm = [1e30, 0.0, 0.0]\n",
            "r.csv": lambda p: p.write_text(arm_csv(*arm_rows(n_joints=2))),
        },
        ["fit", "arm-cmm", "{d}/r.csv", "--arm", "{d}/a.toml"],
        2,
        "offset_mm",
    ),
    (
        "arm-file-huge-com",
        {
            "a.toml": ARM_TOML.replace(
                "theta_deg = 0.0\n", "theta_deg = 0.0\nmass_kg = 2.0\ncom_mm = [1e300, 0.0, 0.0]\n"
            ),
            "r.csv": lambda p: p.write_text(arm_csv(*arm_rows(n_joints=2))),
        },
        ["fit", "arm-cmm", "{d}/r.csv", "--arm", "{d}/a.toml"],
        2,
        "com_mm",
    ),
    (
        "arm-empty-arm",
        {"r.csv": lambda p: p.write_text(arm_csv(*arm_rows()))},
        ["fit", "arm-cmm", "{d}/r.csv", "--arm", ""],
        2,
        "--arm is empty",
    ),
    (
        "discover-arm-empty-arm",
        {"r.csv": lambda p: p.write_text(arm_csv(*arm_rows()))},
        ["discover", "arm-cmm", "{d}/r.csv", "--arm", ""],
        2,
        "--arm is empty",
    ),
    (
        "arm-duplicate-column",
        {"r.csv": arm_csv_with("x_mm", "0")},
        ["fit", "arm-cmm", "{d}/r.csv", "--arm", "ur10"],
        2,
        "named twice",
    ),
    (
        "arm-missing-middle-joint",
        {"r.csv": lambda p: p.write_text(arm_csv(*arm_rows()).replace("q3_deg", "q9_deg"))},
        ["fit", "arm-cmm", "{d}/r.csv", "--arm", "ur10"],
        2,
        "column q3_deg is missing",
    ),
    (
        "arm-zero-std",
        {"r.csv": arm_csv_with("x_std_mm,y_std_mm,z_std_mm", "0.01,0.01,0")},
        ["fit", "arm-cmm", "{d}/r.csv", "--arm", "ur10"],
        2,
        "std of zero or below",
    ),
    (
        "arm-huge-std",
        {"r.csv": arm_csv_with("x_std_mm,y_std_mm,z_std_mm", "0.01,0.01,1e300")},
        ["fit", "arm-cmm", "{d}/r.csv", "--arm", "ur10"],
        2,
        "over 1000 mm",
    ),
    (
        "arm-absurd-temperature",
        {"r.csv": arm_csv_with("temp_c", "1e308")},
        ["fit", "arm-cmm", "{d}/r.csv", "--arm", "ur10"],
        2,
        "temp_c",
    ),
    (
        "arm-holdout-rounds-to-none",
        {"r.csv": lambda p: p.write_text(arm_csv(*arm_rows()))},
        ["fit", "arm-cmm", "{d}/r.csv", "--arm", "ur10", "--holdout", "0.0001"],
        2,
        "holds out no usable row",
    ),
    (
        "arm-effects-empty-name",
        {"r.csv": lambda p: p.write_text(arm_csv(*arm_rows()))},
        ["fit", "arm-cmm", "{d}/r.csv", "--arm", "ur10", "--effects", ""],
        2,
        "--effects is empty",
    ),
    (
        "arm-effects-string-effect",
        {
            "r.csv": lambda p: p.write_text(arm_csv(*arm_rows())),
            "e.json": json.dumps({"scenario": "arm-cmm", "effects": ["transmission"]}),
        },
        ["fit", "arm-cmm", "{d}/r.csv", "--arm", "ur10", "--effects", "{d}/e.json"],
        2,
        "not an object",
    ),
    (
        "arm-effects-unknown",
        {
            "r.csv": lambda p: p.write_text(arm_csv(*arm_rows())),
            "e.json": json.dumps(
                {"scenario": "arm-cmm", "effects": [{"name": "warp_drive", "params": {"joint": 1}}]}
            ),
        },
        ["fit", "arm-cmm", "{d}/r.csv", "--arm", "ur10", "--effects", "{d}/e.json"],
        2,
        "not an arm's",
    ),
    (
        "arm-effects-joint-true",
        {
            "r.csv": lambda p: p.write_text(arm_csv(*arm_rows())),
            "e.json": json.dumps(
                {
                    "scenario": "arm-cmm",
                    "effects": [{"name": "encoder_eccentricity", "params": {"joint": True}}],
                }
            ),
        },
        ["fit", "arm-cmm", "{d}/r.csv", "--arm", "ur10", "--effects", "{d}/e.json"],
        2,
        "names joint True",
    ),
    (
        "arm-effects-harmonics-text",
        {
            "r.csv": lambda p: p.write_text(arm_csv(*arm_rows())),
            "e.json": json.dumps(
                {
                    "scenario": "arm-cmm",
                    "effects": [
                        {"name": "transmission", "params": {"joint": 1, "harmonics": "abc"}}
                    ],
                }
            ),
        },
        ["fit", "arm-cmm", "{d}/r.csv", "--arm", "ur10", "--effects", "{d}/e.json"],
        2,
        "a list of numbers",
    ),
    (
        "arm-effects-edges-ragged",
        {
            "r.csv": lambda p: p.write_text(arm_csv(*arm_rows())),
            "e.json": json.dumps(
                {
                    "scenario": "arm-cmm",
                    "effects": [
                        {"name": "nonsmooth", "params": {"joint": 2, "edges_deg": [[1, 2], [3]]}}
                    ],
                }
            ),
        },
        ["fit", "arm-cmm", "{d}/r.csv", "--arm", "ur10", "--effects", "{d}/e.json"],
        2,
        "a list of numbers",
    ),
    (
        "arm-test-new-frame-on-a-line",
        {
            "r.csv": lambda p: p.write_text(arm_csv(*arm_rows())),
            "t.csv": lambda p: p.write_text(
                arm_csv(
                    arm_rows(seed=1)[0], np.outer(np.arange(60.0), [10.0, 5.0, 2.0]) + [2000, 0, 0]
                )
            ),
        },
        ["fit", "arm-cmm", "{d}/r.csv", "--arm", "ur10", "--test-new-frame", "{d}/t.csv"],
        2,
        "on one line",
    ),
    (
        "arm-test-stale-throughout",
        {
            "r.csv": lambda p: p.write_text(arm_csv(*arm_rows())),
            "t.csv": lambda p: p.write_text(
                arm_csv(arm_rows(seed=1)[0], np.tile([[2000.0, 0, 0]], (60, 1)))
            ),
        },
        ["fit", "arm-cmm", "{d}/r.csv", "--arm", "ur10", "--test", "{d}/t.csv"],
        2,
        "too few to judge",
    ),
]
