"""Bad-input cases, `iso230`: positioning runs it must refuse.

See tests/test_bad_input.py, which runs every case.
"""

from __future__ import annotations


def _run(targets, column="deviation_um"):
    """A bidirectional run, 2 passes each way, at ``targets`` (mm): its deviations 1-4 um, as
    ``deviation_um`` or as ``actual_mm``."""
    rows = [f"target_mm,run,direction,{column}"]
    for k, t in enumerate(targets):
        for run in (1, 2):
            for d in (1, -1):
                dev = 1 + k % 2 + run + (d < 0)
                rows.append(
                    f"{t!r},{run},{d},{dev if column == 'deviation_um' else t + dev / 1000!r}"
                )
    return "\n".join(rows) + "\n"


# (id, files to write {name: text or bytes or callable(path)}, argv with {d} for the case folder,
#  expected exit status, a fragment the message must contain)
CASES = [
    # iso230
    ("iso-missing", {}, ["iso230", "{d}/none.csv"], 2, "cannot read"),
    (  # real and simulated results never share a folder
        "iso-out-holds-another-command-s-results",
        {"r.csv": "target_mm,run,direction,deviation_um\n0,1,1,1\n", "o/fit.json": "{}"},
        ["iso230", "{d}/r.csv", "--out", "{d}/o"],
        2,
        "holds the results of `calibench fit`",
    ),
    (
        "iso-out-with-a-corrupt-mark",
        {"r.csv": "target_mm,run,direction,deviation_um\n0,1,1,1\n", "o/.calibench.json": "{"},
        ["iso230", "{d}/r.csv", "--out", "{d}/o"],
        2,
        "does not say which command wrote",
    ),
    (  # refused as soon as the row after the limit is read, not after the whole file
        "iso-too-many-rows",
        {"r.csv": "target_mm,run,direction,deviation_um\n" + "0,1,1,1\n" * 1_000_001},
        ["iso230", "{d}/r.csv"],
        2,
        "more than 1000000 rows",
    ),
    (
        "iso-no-deviation",
        {"r.csv": "target_mm,run,direction\n0,1,1\n"},
        ["iso230", "{d}/r.csv"],
        2,
        "deviation_um",
    ),
    (  # both columns, saying different things: which one is meant?
        "iso-deviation-and-actual-disagree",
        {"r.csv": "target_mm,run,direction,deviation_um,actual_mm\n10,1,1,1.0,10.5\n"},
        ["iso230", "{d}/r.csv"],
        2,
        "deviation_um and actual_mm - target_mm differ by 499 um",
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
    (  # a run of five passes up and four down: ISO 230-2 pairs them
        "iso-one-pass-missing-one-way",
        {
            "r.csv": "target_mm,run,direction,deviation_um\n"
            + "".join(
                f"{t},{r},{d},{0.3 * r + 0.01 * t + d}\n"
                for r in range(1, 6)
                for d in (1, -1)
                for t in (0, 100, 200)
                if not (d == -1 and r == 5)
            )
        },
        ["iso230", "{d}/r.csv"],
        2,
        "5 runs approach each target in the positive direction and 4 in the negative",
    ),
    (  # a float export's 100.000000001 is target 100 (was: "no reading approached")
        "iso-targets-as-a-float-export-writes-them",
        {
            "r.csv": "target_mm,run,direction,deviation_um\n"
            + "".join(
                f"{t + (1e-9 if r % 2 else -1e-9)},{r},{d},{0.3 * r + 0.01 * t + d}\n"
                for r in range(1, 6)
                for d in (1, -1)
                for t in (0, 100, 200)
            )
        },
        ["iso230", "{d}/r.csv", "--out", "{d}/o"],
        0,
        "",
    ),
    # issue 62, item 8: targets far beyond any axis were taken, their deviations' digits lost
    (
        "iso-target-1e15-mm",
        {"r.csv": _run([0.0, 5e14, 1e15])},
        ["iso230", "{d}/r.csv"],
        2,
        "target_mm is 5e+14, over a kilometre",
    ),
    (  # actual_mm - target_mm at 1e12 mm is 0.1 um coarse: the deviation silently rounded
        "iso-target-1e12-mm-actual",
        {"r.csv": _run([1e12, 1e12 + 100, 1e12 + 200], column="actual_mm")},
        ["iso230", "{d}/r.csv"],
        2,
        "float64 would keep no micrometre",
    ),
    (  # a long axis within the bound is evaluated
        "iso-a-ten-metre-axis",
        {"r.csv": _run([0.0, 5000.0, 10000.0], column="actual_mm")},
        ["iso230", "{d}/r.csv", "--out", "{d}/o"],
        0,
        "",
    ),
]
