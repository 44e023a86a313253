"""Bad-input cases, `fit arm-cmm`: spoiled arm recordings, effects files and arm files.

See tests/test_bad_input.py, which runs every case.
"""

from __future__ import annotations

import json
import os

import numpy as np

from tests.bad_input.files import (
    ARM_TOML,
    UR10_Q,
    arm_csv,
    arm_csv_with,
    arm_rows,
    stage_csv,
)

# (id, files to write {name: text or bytes or callable(path)}, argv with {d} for the case folder,
#  expected exit status, a fragment the message must contain)
CASES = [
    # fit arm-cmm --leave-one-out: two sessions at least, and no other split beside it
    (
        "arm-leave-one-out-one-session",
        {"r.csv": lambda p: p.write_text(arm_csv(*arm_rows()))},
        ["fit", "arm-cmm", "{d}/r.csv", "--arm", "ur10", "--leave-one-out"],
        2,
        "at least two sessions",
    ),
    (
        "arm-leave-one-out-and-holdout",
        {"r.csv": lambda p: p.write_text(arm_csv(*arm_rows()))},
        ["fit", "arm-cmm", "{d}/r.csv", "{d}/r.csv", "--leave-one-out", "--holdout", "0.3"],
        2,
        "--holdout would be another split",
    ),
    (
        "arm-leave-one-out-same-name",
        {
            "a/r.csv": lambda p: p.write_text(arm_csv(*arm_rows())),
            "b/r.csv": lambda p: p.write_text(arm_csv(*arm_rows())),
        },
        ["fit", "arm-cmm", "{d}/a/r.csv", "{d}/b/r.csv", "--arm", "ur10", "--leave-one-out"],
        2,
        "share a file name",
    ),
    (
        "stage-leave-one-out",
        {"r.csv": stage_csv()},
        ["fit", "belt-stage", "{d}/r.csv", "--leave-one-out"],
        2,
        "--leave-one-out applies to arm-cmm only",
    ),
    # fit arm-cmm
    ("arm-missing-file", {}, ["fit", "arm-cmm", "{d}/none.csv", "--arm", "ur10"], 2, "cannot read"),
    (
        "arm-joint-count",
        {"r.csv": lambda p: p.write_text(arm_csv(*arm_rows(n_joints=5)))},
        ["fit", "arm-cmm", "{d}/r.csv", "--arm", "ur10"],
        2,
        "but the arm has 6 joints",
    ),
    (
        "arm-missing-xyz",
        {"r.csv": ",".join(UR10_Q + ["x_mm", "y_mm"]) + "\n" + "1," * 7 + "1\n"},
        ["fit", "arm-cmm", "{d}/r.csv", "--arm", "ur10"],
        2,
        "missing column(s) z_mm",
    ),
    (
        "arm-nan",
        {"r.csv": lambda p: p.write_text(arm_csv(*arm_rows()).replace("\n1", "\nnan", 1))},
        ["fit", "arm-cmm", "{d}/r.csv", "--arm", "ur10"],
        2,
        "r.csv",
    ),
    (
        "arm-radians",
        {"r.csv": lambda p: p.write_text(arm_csv(np.radians(arm_rows()[0]), arm_rows()[1]))},
        ["fit", "arm-cmm", "{d}/r.csv", "--arm", "ur10"],
        2,
        "radians",
    ),
    (
        "arm-metres",
        {"r.csv": lambda p: p.write_text(arm_csv(arm_rows()[0], arm_rows()[1] / 1000))},
        ["fit", "arm-cmm", "{d}/r.csv", "--arm", "ur10"],
        2,
        "metres",
    ),
    (
        "arm-1e300",
        {"r.csv": lambda p: p.write_text(arm_csv(arm_rows()[0], arm_rows()[1] * 1e297))},
        ["fit", "arm-cmm", "{d}/r.csv", "--arm", "ur10"],
        2,
        "r.csv",
    ),
    (
        "arm-too-few",
        {"r.csv": lambda p: p.write_text(arm_csv(*arm_rows(n=8)))},
        ["fit", "arm-cmm", "{d}/r.csv", "--arm", "ur10"],
        2,
        "too few",
    ),
    (
        "arm-one-posture-300",
        {
            "r.csv": lambda p: p.write_text(
                arm_csv(np.tile(arm_rows()[0][:1], (300, 1)), np.tile(arm_rows()[1][:1], (300, 1)))
            )
        },
        ["fit", "arm-cmm", "{d}/r.csv", "--arm", "ur10"],
        2,
        "distinct postures",
    ),
    (
        "arm-negative-std",
        {"r.csv": arm_csv_with("x_std_mm,y_std_mm,z_std_mm", "0.01,0.01,-0.01")},
        ["fit", "arm-cmm", "{d}/r.csv", "--arm", "ur10"],
        2,
        "std of zero or below",
    ),
    (  # one row's std far under any instrument's: it would outweigh every other row
        "arm-tiny-std-one-row",
        {
            "r.csv": lambda p: p.write_text(
                "\n".join(
                    [
                        f"{h},x_std_mm,y_std_mm,z_std_mm"
                        for h in arm_csv(*arm_rows()).splitlines()[:1]
                    ]
                    + [
                        f"{r},{'1e-300' if i == 7 else '0.01'},0.01,0.01"
                        for i, r in enumerate(arm_csv(*arm_rows()).splitlines()[1:])
                    ]
                )
                + "\n"
            )
        },
        ["fit", "arm-cmm", "{d}/r.csv", "--arm", "ur10"],
        2,
        "line 9: a std of 1e-300 mm (under 0.0001 mm",
    ),
    (
        "arm-partial-std",
        {"r.csv": arm_csv_with("x_std_mm", "0.01")},
        ["fit", "arm-cmm", "{d}/r.csv", "--arm", "ur10"],
        2,
        "without the others",
    ),
    (
        "arm-holdout-zero",
        {"r.csv": lambda p: p.write_text(arm_csv(*arm_rows()))},
        ["fit", "arm-cmm", "{d}/r.csv", "--arm", "ur10", "--holdout", "0"],
        2,
        "--holdout",
    ),
    (
        "arm-holdout-big",
        {"r.csv": lambda p: p.write_text(arm_csv(*arm_rows()))},
        ["fit", "arm-cmm", "{d}/r.csv", "--arm", "ur10", "--holdout", "1.5"],
        2,
        "--holdout",
    ),
    (
        "arm-holdout-text",
        {"r.csv": lambda p: p.write_text(arm_csv(*arm_rows()))},
        ["fit", "arm-cmm", "{d}/r.csv", "--arm", "ur10", "--holdout", "most"],
        2,
        "--holdout",
    ),
    (
        "arm-holdout-nan",
        {"r.csv": lambda p: p.write_text(arm_csv(*arm_rows()))},
        ["fit", "arm-cmm", "{d}/r.csv", "--arm", "ur10", "--holdout", "nan"],
        2,
        "--holdout",
    ),
    (
        "arm-model-unknown",
        {"r.csv": lambda p: p.write_text(arm_csv(*arm_rows()))},
        ["fit", "arm-cmm", "{d}/r.csv", "--model", "magic"],
        2,
        "invalid choice",
    ),
    (
        "arm-physics-without-masses",
        {"a.toml": ARM_TOML, "r.csv": lambda p: p.write_text(arm_csv(*arm_rows(n_joints=2)))},
        ["fit", "arm-cmm", "{d}/r.csv", "--arm", "{d}/a.toml", "--model", "physics"],
        2,
        "needs the arm's masses",
    ),
    (
        "arm-same-file-twice",
        {"r.csv": lambda p: p.write_text(arm_csv(*arm_rows()))},
        ["fit", "arm-cmm", "{d}/r.csv", "{d}/r.csv", "--arm", "ur10"],
        2,
        "is given twice",
    ),
    (
        "arm-effects-missing",
        {"r.csv": lambda p: p.write_text(arm_csv(*arm_rows()))},
        ["fit", "arm-cmm", "{d}/r.csv", "--arm", "ur10", "--effects", "{d}/none.json"],
        2,
        "cannot read",
    ),
    (
        "arm-effects-not-json",
        {"r.csv": lambda p: p.write_text(arm_csv(*arm_rows())), "e.json": "{{"},
        ["fit", "arm-cmm", "{d}/r.csv", "--arm", "ur10", "--effects", "{d}/e.json"],
        2,
        "not JSON",
    ),
    (
        "arm-effects-foreign",
        {
            "r.csv": lambda p: p.write_text(arm_csv(*arm_rows())),
            "e.json": json.dumps({"scenario": "belt-stage", "effects": []}),
        },
        ["fit", "arm-cmm", "{d}/r.csv", "--arm", "ur10", "--effects", "{d}/e.json"],
        2,
        "not the discovery.json",
    ),
    (
        "arm-effects-bad-joint",
        {
            "r.csv": lambda p: p.write_text(arm_csv(*arm_rows())),
            "e.json": json.dumps(
                {
                    "scenario": "arm-cmm",
                    "effects": [{"name": "transmission", "params": {"joint": 9, "harmonics": [3]}}],
                }
            ),
        },
        ["fit", "arm-cmm", "{d}/r.csv", "--arm", "ur10", "--effects", "{d}/e.json"],
        2,
        "names joint 9",
    ),
    (
        "arm-effects-per-recording-not-bool",
        {
            "r.csv": lambda p: p.write_text(arm_csv(*arm_rows())),
            "e.json": json.dumps(
                {
                    "scenario": "arm-cmm",
                    "effects": [
                        {
                            "name": "transmission",
                            "params": {"joint": 2, "harmonics": [17], "per_recording": "yes"},
                        }
                    ],
                }
            ),
        },
        ["fit", "arm-cmm", "{d}/r.csv", "--arm", "ur10", "--effects", "{d}/e.json"],
        2,
        "true or false",
    ),
    (
        "arm-test-missing",
        {"r.csv": lambda p: p.write_text(arm_csv(*arm_rows()))},
        ["fit", "arm-cmm", "{d}/r.csv", "--arm", "ur10", "--test", "{d}/none.csv"],
        2,
        "none.csv",
    ),
    (
        "arm-test-joint-count",
        {
            "r.csv": lambda p: p.write_text(arm_csv(*arm_rows())),
            "t.csv": lambda p: p.write_text(arm_csv(*arm_rows(n_joints=7))),
        },
        ["fit", "arm-cmm", "{d}/r.csv", "--arm", "ur10", "--test-new-frame", "{d}/t.csv"],
        2,
        "t.csv",
    ),
    (
        "run-arm-cone-out-of-reach",
        {"a.toml": ARM_TOML},
        ["run", "arm-cmm", "--arm", "{d}/a.toml", "--out", "{d}/o"],
        2,
        "out of the arm Two's reach",
    ),
    (
        "mc-arm-planar",
        {"a.toml": ARM_TOML.replace("alpha_deg = 90.0", "alpha_deg = 0.0")},
        [
            "montecarlo",
            "arm-cmm",
            "--arm",
            "{d}/a.toml",
            "--trials",
            "4",
            "--workers",
            "1",
            "--out",
            "{d}/o",
        ],
        2,
        "every trial's estimate is singular",
    ),
    (
        "mc-arm-one-joint",
        {"a.toml": ARM_TOML.rsplit("[[joint]]", 1)[0]},
        [
            "montecarlo",
            "arm-cmm",
            "--arm",
            "{d}/a.toml",
            "--trials",
            "6",
            "--workers",
            "1",
            "--out",
            "{d}/o",
        ],
        2,
        "every trial's estimate is singular",
    ),
    (
        "arm-file-missing-field",
        {
            "a.toml": ARM_TOML.replace("d_mm = 0.0\n", "", 1),
            "r.csv": lambda p: p.write_text(arm_csv(*arm_rows(n_joints=2))),
        },
        ["fit", "arm-cmm", "{d}/r.csv", "--arm", "{d}/a.toml"],
        2,
        "d_mm",
    ),
    (
        "arm-file-bad-convention",
        {
            "a.toml": ARM_TOML.replace('"dh"', '"euler"'),
            "r.csv": lambda p: p.write_text(arm_csv(*arm_rows(n_joints=2))),
        },
        ["fit", "arm-cmm", "{d}/r.csv", "--arm", "{d}/a.toml"],
        2,
        "convention",
    ),
    (
        "arm-file-not-toml",
        {"a.toml": "[[joint]\n", "r.csv": lambda p: p.write_text(arm_csv(*arm_rows(n_joints=2)))},
        ["fit", "arm-cmm", "{d}/r.csv", "--arm", "{d}/a.toml"],
        2,
        "a.toml",
    ),
    (
        "arm-file-no-joints",
        {
            "a.toml": 'name = "x"\nconvention = "dh"\n',
            "r.csv": lambda p: p.write_text(arm_csv(*arm_rows(n_joints=2))),
        },
        ["fit", "arm-cmm", "{d}/r.csv", "--arm", "{d}/a.toml"],
        2,
        "joint",
    ),
    (
        "arm-file-text-number",
        {
            "a.toml": ARM_TOML.replace("a_mm = 300.0", 'a_mm = "300"'),
            "r.csv": lambda p: p.write_text(arm_csv(*arm_rows(n_joints=2))),
        },
        ["fit", "arm-cmm", "{d}/r.csv", "--arm", "{d}/a.toml"],
        2,
        "a_mm",
    ),
    (
        "arm-file-negative-mass",
        {
            "a.toml": ARM_TOML.replace(
                "theta_deg = 0.0\n", "theta_deg = 0.0\nmass_kg = -2.0\ncom_mm = [0.0, 0.0, 0.0]\n"
            ),
            "r.csv": lambda p: p.write_text(arm_csv(*arm_rows(n_joints=2))),
        },
        ["fit", "arm-cmm", "{d}/r.csv", "--arm", "{d}/a.toml"],
        2,
        "mass",
    ),
    # [transmission]: a cable-driven or coupled arm's coupling and cables
    (
        "arm-coupling-wrong-shape",
        {
            "a.toml": ARM_TOML + "[transmission]\ncoupling = [[1, 0, 0], [0, 1, 0]]\n",
            "r.csv": lambda p: p.write_text(arm_csv(*arm_rows(n_joints=2))),
        },
        ["fit", "arm-cmm", "{d}/r.csv", "--arm", "{d}/a.toml"],
        2,
        "coupling must be 2 rows of 2 numbers",
    ),
    (
        "arm-coupling-singular",
        {
            "a.toml": ARM_TOML + "[transmission]\ncoupling = [[1, 1], [0.5, 0.5]]\n",
            "r.csv": lambda p: p.write_text(arm_csv(*arm_rows(n_joints=2))),
        },
        ["discover", "arm-cmm", "{d}/r.csv", "--arm", "{d}/a.toml"],
        2,
        "coupling is singular",
    ),
    (
        "arm-cable-stiffness-not-positive",
        {
            "a.toml": ARM_TOML + "[transmission]\ncable_stiffness_nm_per_rad = [1000.0, 0.0]\n",
            "r.csv": lambda p: p.write_text(arm_csv(*arm_rows(n_joints=2))),
        },
        ["fit", "arm-cmm", "{d}/r.csv", "--arm", "{d}/a.toml"],
        2,
        "cable_stiffness_nm_per_rad must be 2 positive numbers",
    ),
    (
        "arm-cable-stiffness-nan",
        {
            "a.toml": ARM_TOML + "[transmission]\ncable_stiffness_nm_per_rad = [1000.0, nan]\n",
            "r.csv": lambda p: p.write_text(arm_csv(*arm_rows(n_joints=2))),
        },
        ["run", "arm-cmm", "--arm", "{d}/a.toml", "--out", "{d}/o"],
        2,
        "positive numbers",
    ),
    # Python 3.11's Path.resolve raises RuntimeError on a symbolic link loop: exit 2, not 3
    (
        "arm-symlink-loop",
        {"loop.csv": lambda p: p.symlink_to(p.name)},
        ["fit", "arm-cmm", "{d}/loop.csv", "--arm", "ur10"],
        2,
        "a symbolic link loop",
    ),
    (
        "arm-test-symlink-loop",
        {
            "r.csv": lambda p: p.write_text(arm_csv(*arm_rows())),
            "loop.csv": lambda p: p.symlink_to(p.name),
        },
        ["fit", "arm-cmm", "{d}/r.csv", "--test", "{d}/loop.csv", "--arm", "ur10"],
        2,
        "a symbolic link loop",
    ),
    (  # a TOML of thousands of nested arrays: tomllib recurses
        "arm-file-nested-too-deep",
        {
            "a.toml": "x = " + "[" * 50000 + "]" * 50000 + "\n",
            "r.csv": lambda p: p.write_text(arm_csv(*arm_rows(n_joints=2))),
        },
        ["fit", "arm-cmm", "{d}/r.csv", "--arm", "{d}/a.toml"],
        2,
        "nested too deep",
    ),
    (  # fit arm-cmm <(cat file.csv): the second read found nothing, said as missing columns
        "arm-recording-is-a-pipe",
        {"r.csv": lambda p: os.mkfifo(p)},
        ["fit", "arm-cmm", "{d}/r.csv", "--arm", "ur10"],
        2,
        "a pipe or a device, which can be read only once",
    ),
    (  # the joint columns were counted from a header read without bound
        "arm-recording-without-line-ends",
        {"r.csv": lambda p: p.write_text("q1_deg" + ",q" * 100_000)},
        ["fit", "arm-cmm", "{d}/r.csv", "--arm", "ur10"],
        2,
        "r.csv line 1: over 100,000 characters",
    ),
]
