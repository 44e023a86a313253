"""The bad-input corpus: every verb and the config, fed what users actually feed them.

Each case asserts the CONTRACT's answer to bad input: exit status 2, one line on stderr that
names the problem (the fragment), no traceback, and no output file holding a wrong result. A few
inputs are odd but legitimate (a UTF-8 byte-order mark, CRLF line ends): those must exit 0.
"""

from __future__ import annotations

import dataclasses
import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from calibench.scenarios.cli import main

RESULTS = (
    "report.json",
    "fit.json",
    "discovery.json",
    "summary.json",
    "intrinsics.json",
    "iso230.json",
)
STAGE_HEAD = "x_cmd_mm,y_cmd_mm,x_meas_mm,y_meas_mm"
UR10_TOML = (Path(__file__).resolve().parents[1] / "scenes" / "arms" / "ur10.toml").read_text()
UR10_Q = ["q1_deg", "q2_deg", "q3_deg", "q4_deg", "q5_deg", "q6_deg"]


# --- files the cases are made of ---------------------------------------------------------------
def stage_csv(n=6, err=lambda x, y: (1e-3 * x, 2e-3 * y), extra=""):
    """A grid of n x n stations with a small smooth error: a good recording to spoil."""
    rows = [STAGE_HEAD + extra]
    for x in np.linspace(0, 500, n):
        for y in np.linspace(0, 400, n):
            ex, ey = err(x, y)
            rows.append(f"{x:g},{y:g},{x + ex:.6f},{y + ey:.6f}")
    return "\n".join(rows) + "\n"


def arm_rows(n=60, seed=0, n_joints=6):
    """Postures spread over the workspace and plausible tracker points (mm); not a calibration
    truth, only well-formed data for the cases to spoil."""
    rng = np.random.default_rng(seed)
    q = rng.uniform(-170, 170, (n, n_joints))
    xyz = rng.uniform(-900, 900, (n, 3)) + [2000, -500, 300]
    return q, xyz


def arm_csv(q, xyz, header=None):
    head = header or ",".join(
        [f"q{j + 1}_deg" for j in range(q.shape[1])] + ["x_mm", "y_mm", "z_mm"]
    )
    body = "\n".join(",".join(f"{v:.6f}" for v in row) for row in np.hstack([q, xyz]))
    return head + "\n" + body + "\n"


def arm_csv_with(columns: str, cells: str):
    """A writer of the well-formed arm recording with ``columns`` added to its header and
    ``cells`` to every row (a column of one spoiled value, say)."""

    def write(path):
        head, *rows = arm_csv(*arm_rows()).splitlines()
        path.write_text("\n".join([f"{head},{columns}"] + [f"{r},{cells}" for r in rows]) + "\n")

    return write


def stewart_with(spoil):
    """A writer of a simulated Stewart recording (200 poses, no concealed effect) passed through
    ``spoil(rows)``: rows (n, k) of its CSV's values, changed in place; returns the header too."""

    def write(path):
        from calibench.sim.concealed import stewart_recording

        stewart_recording("null", 0)[0].to_csv(path)
        head, *lines = path.read_text().splitlines()
        rows = np.array([[float(v) for v in line.split(",")] for line in lines])
        spoil(rows, head.split(","))
        path.write_text(
            head + "\n" + "\n".join(",".join(f"{v:.10g}" for v in r) for r in rows) + "\n"
        )

    return write


def _identical(rows, head):
    rows[:] = rows[0]


def _corrupt_leg(rows, head):
    rows[50, head.index("l3_mm")] = -500.0


def _angles_in_radians(rows, head):
    for c in ("rx_deg", "ry_deg", "rz_deg"):
        rows[:, head.index(c)] = np.radians(rows[:, head.index(c)])


ARM_TOML = """name = "Two"
convention = "dh"
[[joint]]
a_mm = 300.0
d_mm = 100.0
alpha_deg = 90.0
theta_deg = 0.0
[[joint]]
a_mm = 250.0
d_mm = 0.0
alpha_deg = 0.0
theta_deg = 0.0
"""


def png(path, size=(480, 640), value=128):
    import cv2

    cv2.imwrite(str(path), np.full((*size, 3), value, np.uint8))
    return path


def _truncated_jpeg(path):
    import cv2

    img = np.random.default_rng(0).integers(0, 255, (240, 320, 3), np.uint8)
    data = cv2.imencode(".jpg", img)[1].tobytes()
    path.write_bytes(data[: len(data) // 2])


# --- the corpus --------------------------------------------------------------------------------
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
    # the config
    (
        "config-missing",
        {},
        ["run", "belt-stage", "--config", "{d}/none.toml"],
        2,
        "cannot read config",
    ),
    (
        "config-folder",
        {"sub/x": ""},
        ["run", "belt-stage", "--config", "{d}/sub"],
        2,
        "cannot read config",
    ),
    (
        "config-not-toml",
        {"c.toml": "this is = = not toml"},
        ["run", "belt-stage", "--config", "{d}/c.toml"],
        2,
        "not valid TOML",
    ),
    (
        "config-binary",
        {"c.toml": b"\xff\xfe\x00\x01"},
        ["run", "belt-stage", "--config", "{d}/c.toml"],
        2,
        "c.toml",
    ),
    (
        "config-unknown-table",
        {"c.toml": "[belt-stagee]\nn_check = 3\n"},
        ["run", "belt-stage", "--config", "{d}/c.toml"],
        2,
        "unknown scenario table",
    ),
    (
        "config-unknown-key",
        {"c.toml": "[belt-stage]\nno_such_key = 3\n"},
        ["run", "belt-stage", "--config", "{d}/c.toml"],
        2,
        "unknown key belt-stage.no_such_key",
    ),
    (
        "config-string-for-number",
        {"c.toml": "[belt-stage.truth]\nboard_yaw_rad = 'big'\n"},
        ["run", "belt-stage", "--config", "{d}/c.toml"],
        2,
        "board_yaw_rad must be a number",
    ),
    (
        "config-bool-for-number",
        {"c.toml": "[belt-stage]\nn_check = true\n"},
        ["run", "belt-stage", "--config", "{d}/c.toml"],
        2,
        "n_check must be a number",
    ),
    (
        "config-float-for-int",
        {"c.toml": "[belt-stage]\nn_intrinsic_views = 2.5\n"},
        ["run", "belt-stage", "--config", "{d}/c.toml"],
        2,
        "n_intrinsic_views = 2.5: must be a whole number",
    ),
    (
        "config-zero-count",
        {"c.toml": "[belt-stage]\nn_intrinsic_views = 0\n"},
        ["run", "belt-stage", "--config", "{d}/c.toml"],
        2,
        "n_intrinsic_views = 0",
    ),
    (
        "config-negative-count",
        {"c.toml": "[arm-cmm]\nn_postures = -5\n"},
        ["run", "arm-cmm", "--config", "{d}/c.toml"],
        2,
        "n_postures = -5",
    ),
    (
        "config-huge-count",
        {"c.toml": "[arm-cmm]\nn_postures = 1000000000\n"},
        ["run", "arm-cmm", "--config", "{d}/c.toml"],
        2,
        "n_postures = 1000000000",
    ),
    (
        "config-huge-count-float",
        {"c.toml": "[arm-cmm]\nn_postures = 1e9\n"},
        ["run", "arm-cmm", "--config", "{d}/c.toml"],
        2,
        "n_postures",
    ),
    (
        "config-negative-sigma",
        {"c.toml": "[arm-cmm]\ncone_point_sigma_mm = -0.01\n"},
        ["run", "arm-cmm", "--config", "{d}/c.toml"],
        2,
        "cone_point_sigma_mm = -0.01: must be zero or positive",
    ),
    (
        "config-negative-noise",
        {"c.toml": "[belt-stage]\ncorner_noise_px = -1.0\n"},
        ["run", "belt-stage", "--config", "{d}/c.toml"],
        2,
        "corner_noise_px",
    ),
    (
        "config-nan",
        {"c.toml": "[belt-stage]\npsf_px = nan\n"},
        ["run", "belt-stage", "--config", "{d}/c.toml"],
        2,
        "psf_px is nan",
    ),
    (
        "config-inf",
        {"c.toml": "[stewart]\ntranslation_mm = inf\n"},
        ["run", "stewart", "--config", "{d}/c.toml"],
        2,
        "translation_mm is inf",
    ),
    (
        "config-zero-stated-sigma",
        {"c.toml": "[stewart]\nstated_reading_sigma_um = 0.0\n"},
        ["run", "stewart", "--config", "{d}/c.toml"],
        2,
        "stated_reading_sigma_um = 0.0: must be positive",
    ),
    (
        "config-zero-stated-length-sigma",
        {"c.toml": "[stewart]\nstated_length_sigma_um = [0.0, 0.0]\n"},
        ["run", "stewart", "--config", "{d}/c.toml"],
        2,
        "needs a or b positive",
    ),
    (
        "config-zero-stated-range-sigma",
        {"c.toml": "[arm-cmm]\nstated_range_sigma_um = [0.0, 1.0]\n"},
        ["run", "arm-cmm", "--config", "{d}/c.toml"],
        2,
        "constant term must be positive",
    ),
    (
        "config-stated-sigma-length",
        {"c.toml": "[arm-cmm]\nstated_range_sigma_um = [5.0]\n"},
        ["run", "arm-cmm", "--config", "{d}/c.toml"],
        2,
        "has 1 values, expected 2",
    ),
    (
        "config-zero-size",
        {"c.toml": "[belt-stage.geometry.board]\nsquare_mm = 0.0\n"},
        ["run", "belt-stage", "--config", "{d}/c.toml"],
        2,
        "square_mm = 0.0: must be positive",
    ),
    (
        "config-negative-size",
        {"c.toml": "[vision-stage.geometry.plate]\npitch_mm = -15.0\n"},
        ["run", "vision-stage", "--config", "{d}/c.toml"],
        2,
        "pitch_mm = -15.0",
    ),
    (
        "config-zero-focal",
        {"c.toml": "[belt-stage.geometry.camera]\nfx = 0\n"},
        ["run", "belt-stage", "--config", "{d}/c.toml"],
        2,
        "fx = 0.0: must be positive",
    ),
    (
        "config-board-1-col",
        {"c.toml": "[belt-stage.geometry.board]\ncols = 1\n"},
        ["run", "belt-stage", "--config", "{d}/c.toml"],
        2,
        "cols = 1",
    ),
    (
        "config-image-huge",
        {"c.toml": "[belt-stage.geometry.camera]\nwidth = 100000\n"},
        ["run", "belt-stage", "--config", "{d}/c.toml"],
        2,
        "width = 100000",
    ),
    (
        "config-table-for-value",
        {"c.toml": "[belt-stage.n_check]\nx = 1\n"},
        ["run", "belt-stage", "--config", "{d}/c.toml"],
        2,
        "n_check must be a number",
    ),
    (
        "config-value-for-table",
        {"c.toml": "[belt-stage]\ntruth = 3\n"},
        ["run", "belt-stage", "--config", "{d}/c.toml"],
        2,
        "truth must be a table",
    ),
    (
        "config-list-for-number",
        {"c.toml": "[belt-stage]\nn_check = [1, 2]\n"},
        ["run", "belt-stage", "--config", "{d}/c.toml"],
        2,
        "n_check must be a number",
    ),
    (
        "config-number-for-list",
        {"c.toml": "[belt-stage.truth]\nerror_x = 3\n"},
        ["run", "belt-stage", "--config", "{d}/c.toml"],
        2,
        "error_x must be a list",
    ),
    (
        "config-list-wrong-length",
        {"c.toml": "[belt-stage.truth]\nerror_x = [0.0, 1e-3]\n"},
        ["run", "belt-stage", "--config", "{d}/c.toml"],
        2,
        "error_x has 2 values, expected 6",
    ),
    (
        "config-list-of-strings",
        {"c.toml": "[belt-stage.truth]\nerror_x = ['a', 0, 0, 0, 0, 0]\n"},
        ["run", "belt-stage", "--config", "{d}/c.toml"],
        2,
        "error_x must be a number",
    ),
    (
        "config-ragged-matrix",
        {"c.toml": "[stewart.geometry]\ninitial_lengths_mm = [650.0, 650.0]\n"},
        ["run", "stewart", "--config", "{d}/c.toml"],
        2,
        "initial_lengths_mm has shape (2,), expected (6,)",
    ),
    (
        "config-homed",
        {"c.toml": "[belt-stage.truth]\nerror_x = [1, 0, 0, 0, 0, 0]\n"},
        ["run", "belt-stage", "--config", "{d}/c.toml"],
        2,
        "homed",
    ),
    (
        "config-number-for-arm",
        {"c.toml": "[arm-cmm]\narm = 3\n"},
        ["run", "arm-cmm", "--config", "{d}/c.toml"],
        2,
        "arm must be a string",
    ),
    (
        "config-grid-float",
        {"c.toml": "[vision-stage]\ngrid = [20.5, 13]\n"},
        ["run", "vision-stage", "--config", "{d}/c.toml"],
        2,
        "grid",
    ),
    (
        "config-runs-one",
        {"c.toml": "[vision-stage]\nruns = 1\n"},
        ["run", "vision-stage", "--config", "{d}/c.toml"],
        2,
        "runs = 1",
    ),
    # fit on stages
    ("fit-missing-file", {}, ["fit", "belt-stage", "{d}/none.csv"], 2, "cannot read"),
    ("fit-folder", {"sub/x": ""}, ["fit", "belt-stage", "{d}/sub"], 2, "sub"),
    ("fit-empty", {"r.csv": ""}, ["fit", "belt-stage", "{d}/r.csv"], 2, "is empty"),
    (
        "fit-header-only",
        {"r.csv": STAGE_HEAD + "\n"},
        ["fit", "belt-stage", "{d}/r.csv"],
        2,
        "no data rows",
    ),
    (
        "fit-missing-column",
        {"r.csv": "x_cmd_mm,y_cmd_mm,x_meas_mm\n1,2,3\n"},
        ["fit", "belt-stage", "{d}/r.csv"],
        2,
        "missing column(s) y_meas_mm",
    ),
    (
        "fit-nan",
        {"r.csv": STAGE_HEAD + "\n1,2,3,nan\n"},
        ["fit", "belt-stage", "{d}/r.csv"],
        2,
        "not finite",
    ),
    (
        "fit-inf",
        {"r.csv": STAGE_HEAD + "\n1,2,inf,4\n"},
        ["fit", "belt-stage", "{d}/r.csv"],
        2,
        "not finite",
    ),
    (
        "fit-text-cell",
        {"r.csv": STAGE_HEAD + "\n1,2,three,4\n"},
        ["fit", "belt-stage", "{d}/r.csv"],
        2,
        "'three', not a number",
    ),
    (
        "fit-short-row",
        {"r.csv": STAGE_HEAD + "\n1,2,3\n"},
        ["fit", "belt-stage", "{d}/r.csv"],
        2,
        "not a number",
    ),
    (
        "fit-semicolons",
        {"r.csv": stage_csv().replace(",", ";")},
        ["fit", "belt-stage", "{d}/r.csv"],
        2,
        "semicolon",
    ),
    (
        "fit-decimal-commas",
        {"r.csv": STAGE_HEAD.replace(",", ";") + "\n1,5;2;3,5;4\n"},
        ["fit", "belt-stage", "{d}/r.csv"],
        2,
        "semicolon",
    ),
    (
        "fit-extra-cell",
        {"r.csv": stage_csv() + "1,2,3,4,5\n"},
        ["fit", "belt-stage", "{d}/r.csv"],
        2,
        "values, the header names 4",
    ),
    (
        "fit-arm-decimal-comma",
        {"r.csv": lambda p: p.write_text(arm_csv(*arm_rows()).replace(".", ",", 1))},
        ["fit", "arm-cmm", "{d}/r.csv", "--arm", "ur10"],
        2,
        "a decimal comma",
    ),
    (
        "fit-latin1",
        {"r.csv": (STAGE_HEAD + ",note\n1,2,3,4,caf\xe9\n").encode("latin-1")},
        ["fit", "belt-stage", "{d}/r.csv"],
        2,
        "not UTF-8",
    ),
    ("fit-binary", {"r.csv": bytes(range(256))}, ["fit", "belt-stage", "{d}/r.csv"], 2, "r.csv"),
    (
        "fit-1e300",
        {"r.csv": stage_csv(err=lambda x, y: (1e300, 1e300))},
        ["fit", "belt-stage", "{d}/r.csv"],
        2,
        "r.csv",
    ),
    (
        "fit-degenerate-line",
        {"r.csv": STAGE_HEAD + "\n" + "".join(f"{x},0,{x},0\n" for x in range(20))},
        ["fit", "belt-stage", "{d}/r.csv"],
        2,
        "degenerate",
    ),
    (
        "fit-too-few",
        {"r.csv": STAGE_HEAD + "\n0,0,0,0\n1,0,1,0\n0,1,0,1\n"},
        ["fit", "belt-stage", "{d}/r.csv"],
        2,
        "3 stations",
    ),
    (
        "fit-one-station-repeated",
        {"r.csv": STAGE_HEAD + "\n" + "5,5,5.001,5.002\n" * 50},
        ["fit", "belt-stage", "{d}/r.csv"],
        2,
        "degenerate",
    ),
    (
        "fit-two-recordings",
        {"r.csv": stage_csv()},
        ["fit", "belt-stage", "{d}/r.csv", "{d}/r.csv"],
        2,
        "one recording",
    ),
    (
        "fit-arm-options-on-stage",
        {"r.csv": stage_csv()},
        ["fit", "belt-stage", "{d}/r.csv", "--holdout", "0.3"],
        2,
        "apply to arm-cmm only",
    ),
    (
        "fit-no-model",
        {"r.csv": stage_csv()},
        ["fit", "probe-scanner", "{d}/r.csv"],
        2,
        "has no fit model",
    ),
    (
        "fit-unknown-scenario",
        {"r.csv": stage_csv()},
        ["fit", "no-such", "{d}/r.csv"],
        2,
        "unknown scenario",
    ),
    (
        "fit-dir-x-7",
        {
            "r.csv": STAGE_HEAD
            + ",dir_x\n"
            + "".join(
                f"{x},{y},{x},{y},7\n" for x in range(0, 500, 100) for y in range(0, 500, 100)
            )
        },
        ["fit", "belt-stage", "{d}/r.csv"],
        2,
        "dir_x",
    ),
    (
        "fit-out-is-file",
        {"r.csv": stage_csv(), "f.txt": "x"},
        ["fit", "belt-stage", "{d}/r.csv", "--out", "{d}/f.txt"],
        2,
        "is a file",
    ),
    # legitimately odd stage recordings: must work
    (
        "fit-bom",
        {"r.csv": ("\ufeff" + stage_csv()).encode("utf-8")},
        ["fit", "belt-stage", "{d}/r.csv", "--out", "{d}/o"],
        0,
        "",
    ),
    (
        "fit-crlf",
        {"r.csv": stage_csv().replace("\n", "\r\n")},
        ["fit", "belt-stage", "{d}/r.csv", "--out", "{d}/o"],
        0,
        "",
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
    # discover
    ("discover-missing", {}, ["discover", "belt-stage", "{d}/none.csv"], 2, "cannot read"),
    (
        "discover-unsupported",
        {"r.csv": stage_csv()},
        ["discover", "lathe", "{d}/r.csv"],
        2,
        "discover supports",
    ),
    (
        "discover-stewart-stage-file",
        {"r.csv": stage_csv()},
        ["discover", "stewart", "{d}/r.csv"],
        2,
        "missing column(s) l1_mm",
    ),
    (
        "discover-stewart-some-dirs",
        {
            "r.csv": "l1_mm,l2_mm,l3_mm,l4_mm,l5_mm,l6_mm,x_mm,y_mm,z_mm,rx_deg,ry_deg,"
            "rz_deg,dir_1\n" + "0,0,0,0,0,0,0,0,750,0,0,0,1\n" * 30
        },
        ["discover", "stewart", "{d}/r.csv"],
        2,
        "dir_1 without the others",
    ),
    (
        "discover-scanner-stage-file",
        {"r.csv": stage_csv()},
        ["discover", "probe-scanner", "{d}/r.csv"],
        2,
        "missing column(s) turn",
    ),
    (
        "discover-scanner-half-turn",
        {
            "r.csv": "turn,theta_deg,rho_mm\n"
            + "".join(f"0,{0.5 * i},{20 + 0.001 * i}\n" for i in range(300))
        },
        ["discover", "probe-scanner", "{d}/r.csv"],
        2,
        "whole turns",
    ),
    (
        "discover-scanner-fractional-turn",
        {"r.csv": "turn,theta_deg,rho_mm\n0.5,0,20\n"},
        ["discover", "probe-scanner", "{d}/r.csv"],
        2,
        "integer",
    ),
    (
        "discover-scanner-other-artefact",
        {
            "r.csv": "turn,theta_deg,rho_mm\n"
            + "".join(f"0,{0.25 * i},{5 + 0.001 * i}\n" for i in range(1440))
        },
        ["discover", "probe-scanner", "{d}/r.csv"],
        2,
        "does not fit the calibration plate",
    ),
    (
        "discover-arm-on-stage",
        {"r.csv": stage_csv()},
        ["discover", "belt-stage", "{d}/r.csv", "--arm", "ur10"],
        2,
        "--arm applies to arm-cmm",
    ),
    (
        "discover-too-few",
        {"r.csv": stage_csv(n=3)},
        ["discover", "belt-stage", "{d}/r.csv"],
        2,
        "at least 20",
    ),
    (
        "discover-1e300",
        {"r.csv": stage_csv(err=lambda x, y: (1e300 * (x + 1), 0.0))},
        ["discover", "belt-stage", "{d}/r.csv"],
        2,
        "r.csv",
    ),
    (
        "discover-arm-radians",
        {"r.csv": lambda p: p.write_text(arm_csv(np.radians(arm_rows()[0]), arm_rows()[1]))},
        ["discover", "arm-cmm", "{d}/r.csv", "--arm", "ur10"],
        2,
        "radians",
    ),
    (
        "discover-arm-joint-count",
        {"r.csv": lambda p: p.write_text(arm_csv(*arm_rows(n_joints=4)))},
        ["discover", "arm-cmm", "{d}/r.csv", "--arm", "ur10"],
        2,
        "joints",
    ),
    (
        "discover-arm-repeated",
        {
            "r.csv": lambda p: p.write_text(
                arm_csv(np.tile(arm_rows()[0][:1], (300, 1)), np.tile(arm_rows()[1][:1], (300, 1)))
            )
        },
        ["discover", "arm-cmm", "{d}/r.csv", "--arm", "ur10"],
        2,
        "distinct postures",
    ),
    (
        "discover-two-stage-recordings",
        {"r.csv": stage_csv()},
        ["discover", "belt-stage", "{d}/r.csv", "{d}/r.csv"],
        2,
        "one recording",
    ),
    (
        "discover-holdout-choice",
        {"r.csv": stage_csv()},
        ["discover", "belt-stage", "{d}/r.csv", "--holdout", "half"],
        2,
        "invalid choice",
    ),
    (
        "discover-arm-holdout",
        {"r.csv": lambda p: p.write_text(arm_csv(*arm_rows()))},
        ["discover", "arm-cmm", "{d}/r.csv", "--arm", "ur10", "--holdout", "rows"],
        2,
        "for the stages",
    ),
    (
        "discover-holdout-rows-no-grid",
        {
            "r.csv": STAGE_HEAD
            + "\n"
            + "".join(
                f"{i * 37 % 500},{i * 53 % 400 + i / 7:.3f},{i * 37 % 500 + 0.001},{i * 53 % 400 + i / 7:.3f}\n"
                for i in range(40)
            )
        },
        ["discover", "belt-stage", "{d}/r.csv", "--holdout", "rows"],
        2,
        "not rows of a grid",
    ),
    (
        "discover-holdout-one-pass",
        {"r.csv": stage_csv()},
        ["discover", "belt-stage", "{d}/r.csv", "--holdout", "pass"],
        2,
        "one pass",
    ),
    (
        "discover-too-many-rows",
        {"r.csv": lambda p: p.write_text(STAGE_HEAD + "\n" + "1,2,3,4\n" * 100_001)},
        ["discover", "belt-stage", "{d}/r.csv"],
        2,
        "100001 rows",
    ),
    (
        "discover-stage-in-um",
        {
            "r.csv": stage_csv()
            .replace(STAGE_HEAD, "h")
            .replace(",", "000,")
            .replace("\n", "000\n")
            .replace("h000", STAGE_HEAD)
        },
        ["discover", "belt-stage", "{d}/r.csv"],
        2,
        "wrong unit (um?)",
    ),
    (
        "fit-stage-in-metres",
        {
            "r.csv": STAGE_HEAD
            + "\n"
            + "".join(
                f"{x / 1000:g},{y / 1000:g},{x / 1000 + 1e-6:g},{y / 1000:g}\n"
                for x in range(0, 500, 50)
                for y in (0, 200)
            )
        },
        ["fit", "belt-stage", "{d}/r.csv"],
        2,
        "metres?",
    ),
    (
        "discover-stage-beyond-travel",
        {"r.csv": stage_csv(n=6).replace("500,", "1500,")},
        ["discover", "belt-stage", "{d}/r.csv"],
        2,
        "travels 0-1000 mm",
    ),
    (
        "fit-underscore-number",
        {"r.csv": stage_csv().replace("\n100,", "\n1_00,", 1)},
        ["fit", "belt-stage", "{d}/r.csv"],
        2,
        "not a number",
    ),
    (
        "fit-line-after-blank-lines",
        {"r.csv": STAGE_HEAD + "\n1,2,1,2\n\n\n3,4,nan,4\n"},
        ["fit", "belt-stage", "{d}/r.csv"],
        2,
        "line 5:",
    ),
    (
        "fit-run-fraction",
        {"r.csv": stage_csv(extra=",run").replace("\n", ",0.5\n").replace("run,0.5", "run")},
        ["fit", "belt-stage", "{d}/r.csv"],
        2,
        "a pass id is a whole number",
    ),
    (
        "discover-stage-temperature-absurd",
        {
            "r.csv": stage_csv(extra=",temp_c")
            .replace("\n", ",1e300\n")
            .replace("temp_c,1e300", "temp_c")
        },
        ["discover", "belt-stage", "{d}/r.csv"],
        2,
        "temp_c is 1e+300",
    ),
    (
        "discover-scanner-in-um",
        {
            "r.csv": "turn,theta_deg,rho_mm\n"
            + "".join(f"0,{0.25 * i},{25000 + i}\n" for i in range(1440))
        },
        ["discover", "probe-scanner", "{d}/r.csv"],
        2,
        "over 1000 mm",
    ),
    (
        "discover-scanner-twin-over-recording",
        {"r.csv": "turn,theta_deg,rho_mm\n0,0,20\n"},
        ["discover", "probe-scanner", "{d}/r.csv", "--twin", "{d}/r.csv"],
        2,
        "would overwrite it",
    ),
    (
        "discover-config-without-the-scenario",
        {"r.csv": "turn,theta_deg,rho_mm\n0,0,20\n", "c.toml": "[stewart]\ntranslation_mm = 5.0\n"},
        ["discover", "probe-scanner", "{d}/r.csv", "--config", "{d}/c.toml"],
        2,
        "no [probe-scanner] table",
    ),
    (
        "discover-stewart-identical-poses",
        {"r.csv": stewart_with(_identical)},
        ["discover", "stewart", "{d}/r.csv"],
        2,
        "1 distinct poses among 200",
    ),
    (
        "discover-stewart-corrupt-row",
        {"r.csv": stewart_with(_corrupt_leg)},
        ["discover", "stewart", "{d}/r.csv"],
        2,
        "data row(s) 51:",
    ),
    (
        "discover-stewart-radians",
        {"r.csv": stewart_with(_angles_in_radians)},
        ["discover", "stewart", "{d}/r.csv"],
        2,
        "a wrong unit",
    ),
    # montecarlo
    ("mc-trials-zero", {}, ["montecarlo", "belt-stage", "--trials", "0"], 2, "--trials"),
    ("mc-trials-negative", {}, ["montecarlo", "belt-stage", "--trials", "-3"], 2, "--trials"),
    ("mc-trials-missing", {}, ["montecarlo", "belt-stage"], 2, "--trials"),
    ("mc-trials-huge", {}, ["montecarlo", "belt-stage", "--trials", "1000000000"], 2, "--trials"),
    (
        "mc-workers-zero",
        {},
        ["montecarlo", "belt-stage", "--trials", "2", "--workers", "0"],
        2,
        "--workers",
    ),
    (
        "mc-workers-beyond-the-machine",
        {},
        ["montecarlo", "belt-stage", "--trials", "2", "--workers", "100000"],
        2,
        "local workers on this machine",
    ),
    (
        "mc-workers-negative",
        {},
        ["montecarlo", "belt-stage", "--trials", "2", "--workers", "-2"],
        2,
        "--workers",
    ),
    (
        "mc-scheduler-not-url",
        {},
        ["montecarlo", "belt-stage", "--trials", "2", "--scheduler", "notaurl", "--out", "{d}/o"],
        2,
        "--scheduler",
    ),
    ("mc-unknown-scenario", {}, ["montecarlo", "no-such", "--trials", "2"], 2, "unknown scenario"),
    (
        "mc-arm-on-stage",
        {},
        ["montecarlo", "belt-stage", "--trials", "2", "--arm", "ur10"],
        2,
        "--arm applies to arm-cmm",
    ),
    (
        "mc-out-is-file",
        {"f.txt": "x"},
        ["montecarlo", "belt-stage", "--trials", "2", "--out", "{d}/f.txt"],
        2,
        "is a file",
    ),
    (
        "mc-corrupt-journal",
        {
            "o/study.json": json.dumps(
                {"scenario": "belt-stage", "seed": 0, "fidelity": "analytic"}
            )
            + "\n",
            "o/trials.jsonl": 'garbage\n{"no": 1}\n[1, 2]\n',
        },
        ["montecarlo", "belt-stage", "--trials", "2", "--out", "{d}/o"],
        2,
        "trials.jsonl",
    ),
    (
        "mc-foreign-journal",
        {"o/trials.jsonl": json.dumps({"trial": 0, "scenario": "stewart"}) + "\n"},
        ["montecarlo", "belt-stage", "--trials", "2", "--out", "{d}/o"],
        2,
        "trials.jsonl",
    ),
    (
        "mc-corrupt-study",
        {"o/study.json": "{not json"},
        ["montecarlo", "belt-stage", "--trials", "2", "--out", "{d}/o"],
        2,
        "study.json",
    ),
    (
        "mc-other-study",
        {"o/study.json": json.dumps({"scenario": "stewart", "seed": 0, "fidelity": "analytic"})},
        ["montecarlo", "belt-stage", "--trials", "2", "--out", "{d}/o"],
        2,
        "different study",
    ),
    # camera
    (
        "camera-no-image",
        {},
        ["camera", "{d}/none.jpg", "--cols", "9", "--rows", "6", "--square-mm", "25"],
        2,
        "no such image",
    ),
    (
        "camera-not-image",
        {"a.jpg": "not an image"},
        [
            "camera",
            "{d}/a.jpg",
            "--cols",
            "9",
            "--rows",
            "6",
            "--square-mm",
            "25",
            "--out",
            "{d}/o",
        ],
        2,
        "a.jpg: not a readable image",
    ),
    (
        "camera-no-board",
        {"a.png": png, "b.png": png, "c.png": png},
        [
            "camera",
            "{d}/a.png",
            "{d}/b.png",
            "{d}/c.png",
            "--cols",
            "9",
            "--rows",
            "6",
            "--square-mm",
            "25",
            "--out",
            "{d}/o",
        ],
        2,
        "board",
    ),
    (
        "camera-cols-zero",
        {"a.png": png},
        ["camera", "{d}/a.png", "--cols", "0", "--rows", "6", "--square-mm", "25"],
        2,
        "--cols",
    ),
    (
        "camera-rows-negative",
        {"a.png": png},
        ["camera", "{d}/a.png", "--cols", "9", "--rows", "-6", "--square-mm", "25"],
        2,
        "--rows",
    ),
    (
        "camera-square-zero",
        {"a.png": png},
        ["camera", "{d}/a.png", "--cols", "9", "--rows", "6", "--square-mm", "0"],
        2,
        "--square-mm",
    ),
    (
        "camera-square-nan",
        {"a.png": png},
        ["camera", "{d}/a.png", "--cols", "9", "--rows", "6", "--square-mm", "nan"],
        2,
        "--square-mm",
    ),
    (
        "camera-square-text",
        {"a.png": png},
        ["camera", "{d}/a.png", "--cols", "9", "--rows", "6", "--square-mm", "big"],
        2,
        "--square-mm",
    ),
    (
        "camera-square-absurd",
        {"a.png": png},
        ["camera", "{d}/a.png", "--cols", "9", "--rows", "6", "--square-mm", "1e-300"],
        2,
        "from 0.001 to 10000 mm",
    ),
    (
        "camera-truncated-jpeg",
        {"a.jpg": lambda p: _truncated_jpeg(p)},
        [
            "camera",
            "{d}/a.jpg",
            "--cols",
            "9",
            "--rows",
            "6",
            "--square-mm",
            "25",
            "--out",
            "{d}/o",
        ],
        2,
        "a.jpg: not a readable image (truncated",
    ),
    (
        "camera-same-file-twice",
        {"a.png": png},
        ["camera", "{d}/a.png", "{d}/a.png", "--cols", "9", "--rows", "6", "--square-mm", "25"],
        2,
        "is given twice",
    ),
    (
        "camera-radial-4",
        {"a.png": png},
        ["camera", "{d}/a.png", "--cols", "9", "--rows", "6", "--square-mm", "25", "--radial", "4"],
        2,
        "invalid choice",
    ),
    (
        "camera-out-is-file",
        {"a.png": png, "f.txt": "x"},
        [
            "camera",
            "{d}/a.png",
            "--cols",
            "9",
            "--rows",
            "6",
            "--square-mm",
            "25",
            "--out",
            "{d}/f.txt",
        ],
        2,
        "is a file",
    ),
    # iso230
    ("iso-missing", {}, ["iso230", "{d}/none.csv"], 2, "cannot read"),
    (
        "iso-no-deviation",
        {"r.csv": "target_mm,run,direction\n0,1,1\n"},
        ["iso230", "{d}/r.csv"],
        2,
        "deviation_um",
    ),
    (
        "iso-direction-0",
        {"r.csv": "target_mm,run,direction,deviation_um\n0,1,0,1\n"},
        ["iso230", "{d}/r.csv"],
        2,
        "direction is 0",
    ),
    (
        "iso-nan",
        {"r.csv": "target_mm,run,direction,deviation_um\n0,1,1,nan\n"},
        ["iso230", "{d}/r.csv"],
        2,
        "not finite",
    ),
    (
        "iso-one-direction",
        {
            "r.csv": "target_mm,run,direction,deviation_um\n"
            + "".join(f"{t},{r},1,1\n" for t in (0, 10) for r in (1, 2))
        },
        ["iso230", "{d}/r.csv"],
        2,
        "negative direction",
    ),
]

# the photo cases that need the shared data (real boards): (id, builder(shared, d) -> argv, fragment)
PHOTO_CASES = [
    ("camera-same-photo-thrice", "the same view as copy0.jpg"),
    ("camera-first-photo-other-size", None),  # legitimately odd: the twelve others calibrate
]


def _materialise(d: Path, files: dict) -> None:
    for name, content in files.items():
        p = d / name
        p.parent.mkdir(parents=True, exist_ok=True)
        if callable(content):
            content(p)
        elif isinstance(content, bytes):
            p.write_bytes(content)
        else:
            p.write_text(content)


def _check(capsys, d: Path, argv: list[str], status: int, fragment: str) -> None:
    argv = [a.replace("{d}", str(d)) for a in argv]
    before = {p for p in d.rglob("*")}
    got = main(argv)
    err = capsys.readouterr().err.strip()
    assert "Traceback" not in err, err
    if status == 0:
        assert got == 0, err
        return
    assert got == status, f"exit {got}: {err}"
    lines = err.splitlines()
    assert len(lines) == 1, err
    assert fragment in err, err
    new = {p for p in d.rglob("*")} - before
    assert not [p for p in new if p.name in RESULTS], new


def test_the_corpus_is_large_and_distinct():
    ids = [c[0] for c in CASES] + [c[0] for c in PHOTO_CASES]
    assert len(ids) == len(set(ids))
    assert len(ids) >= 100


@pytest.mark.parametrize("case", CASES, ids=[c[0] for c in CASES])
def test_bad_input(case, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)  # a default --out lands in the case's folder
    _, files, argv, status, fragment = case
    _materialise(tmp_path, files)
    _check(capsys, tmp_path, argv, status, fragment)


@pytest.mark.parametrize("case", PHOTO_CASES, ids=[c[0] for c in PHOTO_CASES])
def test_bad_photos(case, shared_data, tmp_path, capsys, monkeypatch):
    import cv2

    monkeypatch.chdir(tmp_path)
    name, fragment = case
    left = sorted((shared_data / "opencv_left").glob("*.jpg"))
    if name == "camera-same-photo-thrice":
        paths = []
        for k in range(3):
            paths.append(tmp_path / f"copy{k}.jpg")
            shutil.copy(left[0], paths[-1])
    else:  # the first photo a different size, the other twelve fine
        img = cv2.imread(str(left[0]))
        cv2.imwrite(str(tmp_path / "first.png"), cv2.resize(img, (320, 240)))
        paths = [tmp_path / "first.png"] + left[1:]
    argv = (
        ["camera"]
        + [str(p) for p in paths]
        + ["--cols", "9", "--rows", "6", "--square-mm", "25", "--out", str(tmp_path / "o")]
    )
    _check(capsys, tmp_path, argv, 0 if fragment is None else 2, fragment or "")
    if fragment is None:
        r = json.loads((tmp_path / "o" / "intrinsics.json").read_text())
        assert len(r["used"]) == 12 and "differs" in r["rejected"]["first.png"]


def test_every_default_config_passes_its_own_validation():
    """The ranges the config checks (counts, scatters, sizes) must admit every scenario's defaults."""
    from calibench.scenarios.config import override
    from calibench.scenarios.registry import SCENARIOS

    def table(o):
        out = {}
        for f in dataclasses.fields(o):
            v = getattr(o, f.name)
            out[f.name] = (
                table(v)
                if dataclasses.is_dataclass(v)
                else v.tolist()
                if hasattr(v, "tolist")
                else list(v)
                if isinstance(v, tuple)
                else v
            )
        return out

    for name, s in SCENARIOS.items():
        c = s.config()
        assert table(override(c, table(c), name)) == table(c)


def test_ctrl_c_during_a_study_is_one_line_and_keeps_the_trials(tmp_path):
    """SIGINT to the whole process group (what a terminal's Ctrl-C does): the parent says one
    line and exits 130, the workers print nothing, the journal keeps what finished."""
    import os
    import signal
    import subprocess
    import sys
    import time

    out = tmp_path / "study"
    env = {**os.environ, "MUJOCO_GL": "egl"}
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "calibench.scenarios.cli",
            "montecarlo",
            "belt-stage",
            "--trials",
            "400",
            "--workers",
            "1",
            "--out",
            str(out),
        ],
        stderr=subprocess.PIPE,
        stdout=subprocess.DEVNULL,
        env=env,
        start_new_session=True,
        text=True,
    )
    journal = out / "trials.jsonl"
    deadline = time.time() + 120
    while time.time() < deadline and not (journal.exists() and journal.stat().st_size > 0):
        time.sleep(0.2)
    os.killpg(proc.pid, signal.SIGINT)
    try:
        _, err = proc.communicate(timeout=60)
    finally:  # never leave a study running behind the tests
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    assert proc.returncode == 130, err
    assert err.strip().splitlines() == [
        "calibench: interrupted; finished trials are kept, rerun the same command to resume"
    ], err
    rows = [json.loads(line) for line in journal.read_text().splitlines() if line.strip()]
    assert rows and all(r["ok"] for r in rows)
