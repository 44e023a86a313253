"""Bad-input cases, the command line itself: verbs, seeds, --out, and `run`'s arm and
cones.

See tests/test_bad_input.py, which runs every case.
"""

from __future__ import annotations

from tests.bad_input.files import (
    ARM_TOML,
    UR10_TOML,
    stage_csv,
)

# (id, files to write {name: text or bytes or callable(path)}, argv with {d} for the case folder,
#  expected exit status, a fragment the message must contain)
CASES = [
    # the command line itself
    ("no-command", {}, [], 2, "required"),
    ("unknown-verb", {}, ["frobnicate"], 2, "invalid choice"),
    ("run-no-scenario", {}, ["run"], 2, "required"),
    ("run-unknown-scenario", {}, ["run", "no-such"], 2, "unknown scenario 'no-such'"),
    ("run-seed-negative", {}, ["run", "belt-stage", "--seed", "-1"], 2, "--seed"),
    ("run-seed-text", {}, ["run", "belt-stage", "--seed", "abc"], 2, "--seed"),
    ("run-seed-float", {}, ["run", "belt-stage", "--seed", "1.5"], 2, "--seed"),
    ("run-seed-huge", {}, ["run", "belt-stage", "--seed", "1" + "0" * 30], 2, "--seed"),
    ("run-fidelity", {}, ["run", "belt-stage", "--fidelity", "photoreal"], 2, "invalid choice"),
    (  # no camera: a report labelled render whose sensors were never rendered would mislead
        "run-render-without-a-camera",
        {},
        ["run", "stewart", "--fidelity", "render"],
        2,
        "stewart's instruments are geometric",
    ),
    (  # the first scenario's folder is a file: one line, not an internal error
        "run-all-scenario-folder-is-file",
        {"o/belt-stage": "x"},
        ["run", "all", "--out", "{d}/o"],
        2,
        "cannot write there",
    ),
    (
        "run-out-is-file",
        {"f.txt": "x"},
        ["run", "belt-stage", "--out", "{d}/f.txt"],
        2,
        "is a file",
    ),
    (
        "run-out-under-file",
        {"f.txt": "x"},
        ["run", "belt-stage", "--out", "{d}/f.txt/sub"],
        2,
        "--out",
    ),
    ("run-out-unwritable", {}, ["run", "belt-stage", "--out", "/proc/calibench-out"], 2, "--out"),
    (  # said before the run, not after it as an internal error
        "run-save-images-is-file",
        {"f.txt": "x"},
        ["run", "belt-stage", "--save-images", "{d}/f.txt", "--out", "{d}/o"],
        2,
        "--save-images",
    ),
    (
        "run-save-images-unwritable",
        {},
        ["run", "belt-stage", "--save-images", "/proc/calibench-views", "--out", "{d}/o"],
        2,
        "--save-images /proc/calibench-views: cannot write there",
    ),
    (
        "run-out-name-too-long",
        {},
        ["run", "belt-stage", "--out", "{d}/" + "x" * 300],
        2,
        "File name too long",
    ),
    (
        "fit-out-empty",
        {"r.csv": stage_csv()},
        ["fit", "belt-stage", "{d}/r.csv", "--out", ""],
        2,
        "--out: is empty",
    ),
    (
        "run-arm-cones-coincide",
        {
            "c.toml": "[arm-cmm.truth]\ncone_a_mm = [450.0, 250.0, -150.0]\n"
            "cone_b_mm = [450.0, 250.0, -150.0]\n"
        },
        ["run", "arm-cmm", "--config", "{d}/c.toml", "--out", "{d}/o"],
        2,
        "coincide",
    ),
    (
        "mc-arm-cones-coincide",
        {
            "c.toml": "[arm-cmm.truth]\ncone_a_mm = [450.0, 250.0, -150.0]\n"
            "cone_b_mm = [450.0, 250.5, -150.0]\n"
        },
        ["montecarlo", "arm-cmm", "--config", "{d}/c.toml", "--trials", "2", "--out", "{d}/o"],
        2,
        "coincide",
    ),
    (
        "run-arm-name-newline",
        {"a.toml": ARM_TOML.replace('name = "Two"', 'name = "Two\\nlines"')},
        ["run", "arm-cmm", "--arm", "{d}/a.toml", "--out", "{d}/o"],
        2,
        "control character",
    ),
    (
        "run-arm-cones-outside-ranges",
        {
            "a.toml": 'name = "UR10narrow"\n'
            + "\n".join(
                line + ("\nrange_deg = [-5.0, 5.0]" if line.startswith("theta_deg") else "")
                for line in UR10_TOML.splitlines()
                if not line.startswith("name")
            )
        },
        ["run", "arm-cmm", "--arm", "{d}/a.toml", "--out", "{d}/o"],
        2,
        "out of the arm UR10narrow's reach",
    ),
    ("run-arm-on-stage", {}, ["run", "belt-stage", "--arm", "ur10"], 2, "--arm applies to arm-cmm"),
    ("run-arm-missing", {}, ["run", "arm-cmm", "--arm", "{d}/none.toml"], 2, "none.toml"),
    ("run-arm-unknown-builtin", {}, ["run", "arm-cmm", "--arm", "kuka"], 2, "kuka"),
]

# issue 62: an output never written through a link, a user's file never replaced, an input never
# an output (tests/scenarios/test_outputs_users_files.py checks what each leaves)
_FIT = ["fit", "belt-stage", "{d}/r.csv", "--out", "{d}/o"]
CASES += [
    (  # a link in a folder no command marked: a user's file by an output's name
        "out-link-at-fit-json",
        {"r.csv": stage_csv(), "v/p": "PRECIOUS", "o/fit.json": lambda p: p.symlink_to("../v/p")},
        _FIT,
        2,
        "fit.json",
    ),
    (
        "out-dangling-link-at-fit-json",
        {"r.csv": stage_csv(), "o/fit.json": lambda p: p.symlink_to("../v/none")},
        _FIT,
        2,
        "fit.json",
    ),
    (
        "out-lock-is-a-link",
        {"r.csv": stage_csv(), "o/.calibench.lock": lambda p: p.symlink_to("../v/lock")},
        _FIT,
        2,
        ".calibench.lock is a symbolic link",
    ),
    (
        "out-mark-is-a-dangling-link",
        {"r.csv": stage_csv(), "o/.calibench.json": lambda p: p.symlink_to("../v/mark")},
        _FIT,
        2,
        "(a symbolic link)",
    ),
    (
        "out-mark-is-a-folder",
        {"r.csv": stage_csv(), "o/.calibench.json": lambda p: p.mkdir()},
        _FIT,
        2,
        "(not a file)",
    ),
    (
        "out-mark-scenario-is-a-number",
        {"r.csv": stage_csv(), "o/.calibench.json": '{"command": "fit", "scenario": 5}'},
        _FIT,
        2,
        "does not say which command wrote",
    ),
    ("out-mark-is-a-list", {"r.csv": stage_csv(), "o/.calibench.json": "[]"}, _FIT, 2, "corrupt?"),
    (
        "out-holds-a-user-s-report",
        {"o/report.json": '{"mine": true}'},
        ["run", "stewart", "--no-rrd", "--out", "{d}/o", "--force"],
        2,
        "the results of `calibench run` by name only (report.json)",
    ),
    (
        "out-holds-a-user-s-intrinsics",
        {"r.csv": "target_mm,run,direction,deviation_um\n0,1,1,1\n", "o/intrinsics.json": "{}"},
        ["iso230", "{d}/r.csv", "--out", "{d}/o"],
        2,
        "the results of `calibench camera` by name only",
    ),
    (
        "out-holds-a-user-s-error-log",
        {"r.csv": stage_csv(), "o/error.log": "my own notes\n"},
        _FIT,
        2,
        "error.log",
    ),
    (
        "out-inside-a-claim",
        {"r.csv": stage_csv()},
        ["fit", "belt-stage", "{d}/r.csv", "--out", "{d}/x/.calibench-claim"],
        2,
        ".calibench-claim is calibench's own name",
    ),
    (  # its own residuals as its recording: --force or a rerun would replace the input
        "fit-arm-its-own-residuals",
        {"calibench-out/arm-cmm-fit/residuals.csv": "file,row,role,ex_mm,ey_mm,ez_mm\n"},
        ["fit", "arm-cmm", "calibench-out/arm-cmm-fit/residuals.csv"],
        2,
        "an input is one of the files calibench writes or replaces",
    ),
    (
        "discover-twin-at-the-discovery",
        {"r.csv": stage_csv()},
        ["discover", "belt-stage", "{d}/r.csv", "--out", "{d}/o", "--twin", "{d}/o/discovery.json"],
        2,
        "--twin is one of the files calibench writes or replaces",
    ),
    (
        "discover-twin-at-the-mark",
        {"r.csv": stage_csv()},
        ["discover", *_FIT[1:], "--twin", "{d}/o/.calibench.json"],
        2,
        "--twin is one of the files",
    ),
    (
        "run-save-images-over-a-user-s-truth",
        {"v/truth.json": '{"mine": 1}', "v/view00.png": b"\x89PNG mine"},
        ["run", "belt-stage", "--save-images", "{d}/v", "--out", "{d}/o"],
        2,
        "not written by `calibench run belt-stage --save-images`",
    ),
    (
        "run-save-images-view-is-a-link",
        {"v/view00.png": lambda p: p.symlink_to("../elsewhere.png")},
        ["run", "belt-stage", "--save-images", "{d}/v", "--out", "{d}/o"],
        2,
        "view00.png is a symbolic link",
    ),
    (  # a newline inside an argument: still one line
        "argument-with-a-newline",
        {},
        ["fit", "belt-stage", "{d}/no\nsuch.csv", "--out", "{d}/o"],
        2,
        "no\\nsuch.csv",
    ),
    (
        "seed-with-a-newline",
        {},
        ["run", "belt-stage", "--seed", "1\n2"],
        2,
        "--seed",
    ),
]
