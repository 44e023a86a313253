"""Bad-input cases, `discover`: stage, arm and Stewart recordings it must refuse.

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


def simulated(kind: str, *args, **kw):
    """A writer of a simulated recording of ``kind`` (``stage``, ``scanner``, ``arm``,
    ``stewart``): the concealed suite's recording function's, its arguments passed on."""

    def write(path):
        from calibench.sim import concealed

        make = {
            "stage": concealed.stage_recording,
            "scanner": concealed.scanner_recording,
            "arm": concealed.arm_recording,
            "stewart": concealed.stewart_recording,
        }[kind]
        make(*args, **kw)[0].to_csv(path)

    return write


def _identical(rows, head):
    rows[:] = rows[0]


def _corrupt_leg(rows, head):
    rows[50, head.index("l3_mm")] = -500.0


def _corrupt_pose(rows, head):
    rows[80, head.index("ry_deg")] = 9.9e9  # one row's pose corrupt, the others in degrees


def _angles_in_radians(rows, head):
    for c in ("rx_deg", "ry_deg", "rz_deg"):
        rows[:, head.index(c)] = np.radians(rows[:, head.index(c)])


# (id, files to write {name: text or bytes or callable(path)}, argv with {d} for the case folder,
#  expected exit status, a fragment the message must contain)
CASES = [
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
        "discover-same-recording-twice",
        {"r.csv": stage_csv()},
        ["discover", "belt-stage", "{d}/r.csv", "{d}/r.csv"],
        2,
        "given twice",
    ),
    (
        "discover-stage-temp-in-one",
        {
            "r.csv": stage_csv(),
            "warm.csv": lambda p: p.write_text(
                "\n".join(
                    f"{line},temp_c" if i == 0 else f"{line},{20 + 0.01 * i:.2f}"
                    for i, line in enumerate(stage_csv().splitlines())
                )
                + "\n"
            ),
        },
        ["discover", "belt-stage", "{d}/r.csv", "{d}/warm.csv"],
        2,
        "temperature in all",
    ),
    (
        "discover-stage-other-machine",
        {
            "a.csv": simulated("stage", "belt-stage", "null", 5),
            "b.csv": simulated("stage", "belt-stage", "null", 8),
        },
        ["discover", "belt-stage", "{d}/a.csv", "{d}/b.csv"],
        2,
        "not of the same machine: their error maps differ",
    ),
    (
        "discover-scanner-other-machine",
        {
            "a.csv": simulated("scanner", "null", 1),
            "b.csv": simulated("scanner", "null", 2, plate_turn_deg=30.0),
        },
        ["discover", "probe-scanner", "{d}/a.csv", "{d}/b.csv"],
        2,
        "recording 2 is not of the same machine and plate",
    ),
    (
        "discover-arm-other-machine",
        {
            "a.csv": simulated("arm", "null", 40, n=120, arm="ur10"),
            "b.csv": simulated("arm", "null", 41, n=120, arm="ur10", machine=3),
        },
        ["discover", "arm-cmm", "{d}/a.csv", "{d}/b.csv", "--arm", "ur10"],
        2,
        "recording 2 is not of recording 1's arm",
    ),
    (
        "discover-stewart-other-machine",
        {
            "a.csv": simulated("stewart", "null", 100, n_poses=40),
            "b.csv": simulated("stewart", "null", 200, n_poses=40),
        },
        ["discover", "stewart", "{d}/a.csv", "{d}/b.csv"],
        2,
        "recording 2 is not of recording 1's platform",
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
                f"{i * 37 % 500},{i * 53 % 400 + i / 7:.3f},"
                f"{i * 37 % 500 + 0.001},{i * 53 % 400 + i / 7:.3f}\n"
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
        "more than 100000 rows",
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
        {  # the last column of stations commanded and measured 1000 mm further
            "r.csv": stage_csv(n=6)
            .replace("\n500,", "\n1500,")
            .replace(",500.500000,", ",1501.500000,")
        },
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
    (  # Python 3.11's Path.resolve raises RuntimeError on a symbolic link loop: exit 2, not 3
        "discover-twin-symlink-loop",
        {"r.csv": "turn,theta_deg,rho_mm\n0,0,20\n", "loop.toml": lambda p: p.symlink_to(p.name)},
        ["discover", "probe-scanner", "{d}/r.csv", "--twin", "{d}/loop.toml"],
        2,
        "a symbolic link loop",
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
    (  # one corrupt pose was blamed on the unit of the whole file
        "discover-stewart-corrupt-pose",
        {"r.csv": stewart_with(_corrupt_pose)},
        ["discover", "stewart", "{d}/r.csv"],
        2,
        "line 82: an angle of 9.9e+09 deg in rx/ry/rz, where the other rows are in range",
    ),
    # issue 62, item 8: run set to the row index: each "pass" one row, both effects "confirmed
    # by leaving one pass out"
    (
        "discover-run-is-the-row-index",
        {
            "r.csv": lambda p: p.write_text(
                "\n".join(
                    line + ("," + ("run" if k == 0 else str(k)))
                    for k, line in enumerate(stage_csv().splitlines())
                )
                + "\n"
            )
        },
        ["discover", "belt-stage", "{d}/r.csv"],
        2,
        "column run names 36 passes for 36 rows",
    ),
]
