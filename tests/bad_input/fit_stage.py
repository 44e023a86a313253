"""Bad-input cases, `fit` on stages: spoiled stage recordings, and legitimately odd ones that
must work.

See tests/test_bad_input.py, which runs every case.
"""

from __future__ import annotations

import numpy as np

from tests.bad_input.files import (
    STAGE_HEAD,
    arm_csv,
    arm_rows,
    stage_csv,
)

# (id, files to write {name: text or bytes or callable(path)}, argv with {d} for the case folder,
#  expected exit status, a fragment the message must contain)
CASES = [
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
        ["fit", "belt-stage", "{d}/r.csv", "--holdout", "0.3", "--model", "physics"],
        2,
        "--holdout, --model apply to arm-cmm only",
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
    (  # a usual name of an optional column: it would be ignored, and discover's finding with it
        "fit-temperature-column-misnamed",
        {
            "r.csv": stage_csv(extra=",temperature_c")
            .replace("\n", ",20\n")
            .replace("temperature_c,20", "temperature_c")
        },
        ["fit", "belt-stage", "{d}/r.csv"],
        2,
        "column 'temperature_c' is not one the format knows, so temp_c would be ignored",
    ),
    (
        "fit-direction-column-in-capitals",
        {"r.csv": stage_csv(extra=",DIR_X").replace("\n", ",1\n").replace("DIR_X,1", "DIR_X")},
        ["fit", "belt-stage", "{d}/r.csv"],
        2,
        "if it is dir_x, name it so",
    ),
    (  # a frozen reading: the error is minus the command, which a map fits with R^2 = 1
        "fit-frozen-measured-column",
        {"r.csv": stage_csv(err=lambda x, y: (5.0 - x, 2e-3 * y))},
        ["fit", "belt-stage", "{d}/r.csv"],
        2,
        "x_meas_mm moves 0 mm per mm of x_cmd_mm",
    ),
    (
        "fit-measured-columns-swapped",
        {"r.csv": stage_csv(err=lambda x, y: (y - x, x - y))},
        ["fit", "belt-stage", "{d}/r.csv"],
        2,
        "do not follow the commanded ones",
    ),
    (  # held out, the copy would score the model on its own rows (and numpy's warnings leaked)
        "discover-pass-repeated",
        {
            "r.csv": lambda p: p.write_text(
                STAGE_HEAD
                + ",run\n"
                + "".join(f"{r},{k}\n" for k in (0, 1) for r in stage_csv().splitlines()[1:])
            )
        },
        ["discover", "belt-stage", "{d}/r.csv"],
        2,
        "pass 1 repeats pass 0 row for row",
    ),
    (
        "discover-file-appended-to-itself",
        {"r.csv": stage_csv() + "".join(r + "\n" for r in stage_csv().splitlines()[1:])},
        ["discover", "belt-stage", "{d}/r.csv"],
        2,
        "its second half repeats its first",
    ),
    (  # a ballbar's circle: 1, x^2 and y^2 repeat each other (c0's std was 150 mm, exit 0)
        "fit-stations-on-a-circle",
        {
            "r.csv": lambda p: p.write_text(
                STAGE_HEAD
                + "\n"
                + "".join(
                    f"{500 + 300 * np.cos(a):.3f},{500 + 300 * np.sin(a):.3f},"
                    f"{500.8 + 300 * np.cos(a):.5f},{501 + 300 * np.sin(a):.5f}\n"
                    for a in np.linspace(0, 2 * np.pi, 40, endpoint=False)
                )
            )
        },
        ["fit", "belt-stage", "{d}/r.csv"],
        2,
        "lie on a line or a curve (a circle?)",
    ),
    # legitimately odd stage recordings: must work
    (  # a read-out coarser than the repeatability repeats a pass: the map's fit takes it
        "fit-pass-repeated-to-the-last-digit",
        {"r.csv": stage_csv() + "".join(r + "\n" for r in stage_csv().splitlines()[1:])},
        ["fit", "belt-stage", "{d}/r.csv", "--out", "{d}/o"],
        0,
        "",
    ),
    (  # an axis without error: no R^2 (was NaN in fit.json, which is not JSON)
        "fit-an-axis-without-error",
        {"r.csv": stage_csv(err=lambda x, y: (1e-3 * x + 1e-6 * x * y, 0.0))},
        ["fit", "belt-stage", "{d}/r.csv", "--out", "{d}/o"],
        0,
        "",
    ),
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
    (  # refused as soon as the row after the limit is read, not after the whole file
        "fit-stage-too-many-rows",
        {"r.csv": lambda p: p.write_text(STAGE_HEAD + "\n" + "1,2,3,4\n" * 1_000_001)},
        ["fit", "belt-stage", "{d}/r.csv"],
        2,
        "more than 1000000 rows",
    ),
    # issue 62, item 4: a line's length is bounded, read in bounded chunks
    (  # a header, one row and 50 million commas: exit 0 at 916 MB (one million here)
        "fit-a-line-of-commas",
        {"r.csv": lambda p: p.write_text(STAGE_HEAD + "\n1,2,3,4" + "," * 1_000_000 + "\n")},
        ["fit", "belt-stage", "{d}/r.csv"],
        2,
        "r.csv line 2: over 100,000 characters without a line end",
    ),
    (  # no line end at all: grew without bound
        "fit-dev-zero",
        {},
        ["fit", "belt-stage", "/dev/zero", "--out", "{d}/o"],
        2,
        "/dev/zero line 1: over 100,000 characters",
    ),
    (  # a row's empty cells beyond the header's are harmless, as before
        "fit-trailing-empty-cells",
        {"r.csv": stage_csv().replace("\n", ",,,\n")},
        ["fit", "belt-stage", "{d}/r.csv", "--out", "{d}/o"],
        0,
        "",
    ),
    # issue 62, item 10: another encoding said as such
    (  # was "line contains NUL"
        "fit-utf16le-without-bom",
        {"r.csv": stage_csv().encode("utf-16-le")},
        ["fit", "belt-stage", "{d}/r.csv"],
        2,
        "r.csv is not UTF-8 text: it looks like UTF-16",
    ),
    (
        "fit-utf16-with-bom",
        {"r.csv": stage_csv().encode("utf-16")},
        ["fit", "belt-stage", "{d}/r.csv"],
        2,
        "r.csv is not UTF-8 text (UTF-16, by its byte-order mark)",
    ),
    (
        "fit-nul-characters",
        {"r.csv": stage_csv().replace("0,", "0\x00,", 1).encode()},
        ["fit", "belt-stage", "{d}/r.csv"],
        2,
        "it holds NUL characters",
    ),
    # issue 62, item 8: a column named twice in two cases was read once, silently
    (
        "fit-column-in-two-cases",
        {
            "r.csv": stage_csv(extra=",X_CMD_MM")
            .replace("\n", ",0\n")
            .replace(",X_CMD_MM,0", ",X_CMD_MM", 1)
        },
        ["fit", "belt-stage", "{d}/r.csv"],
        2,
        "columns x_cmd_mm and X_CMD_MM both name x_cmd_mm",
    ),
    (
        "fit-column-and-its-alias",
        {
            "r.csv": stage_csv(extra=",temp_c,temperature_c")
            .replace("\n", ",20,20\n")
            .replace(",temp_c,temperature_c,20,20", ",temp_c,temperature_c", 1)
        },
        ["fit", "belt-stage", "{d}/r.csv"],
        2,
        "columns temp_c and temperature_c both name temp_c",
    ),
]
