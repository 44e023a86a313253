"""``calibench iso230``: a user's bidirectional run in, the ISO 230-2 figures out.

The run is built from a known axis: a systematic deviation, a reversal error, and a scatter whose
sample std is exact (offsets -2..2 times k: s = k sqrt(10 / 4)). Every figure then has a closed
form, and the command must find it from the shuffled rows of the CSV.
"""

import json

import numpy as np
import pytest

from calibench.scenarios.cli import main

TARGETS = np.linspace(0.0, 200.0, 9)
K_UP, K_DOWN = 0.4, 0.6  # um


def _axis():
    mean_bi = 3.0 + 0.02 * TARGETS - 1.5e-4 * TARGETS**2  # um
    reversal = 1.0 + 0.5 * np.sin(TARGETS / 40)  # up minus down, um
    return mean_bi + reversal / 2, mean_bi - reversal / 2, reversal


def _write(path, column="deviation_um", seed=0):
    up, down, _ = _axis()
    offsets = np.array([-2.0, -1.0, 0.0, 1.0, 2.0])
    rows = []
    for i, t in enumerate(TARGETS):
        for j, o in enumerate(offsets):
            for d, m, k in ((+1, up[i], K_UP), (-1, down[i], K_DOWN)):
                dev = m + k * o
                values = {"deviation_um": [dev], "actual_mm": [t + dev / 1000]}
                values["both"] = values["deviation_um"] + values["actual_mm"]
                rows.append(f"{t:g},{j + 1},{d}," + ",".join(f"{v:.9f}" for v in values[column]))
    rows = list(np.random.default_rng(seed).permutation(rows))
    header = "deviation_um,actual_mm" if column == "both" else column
    path.write_text(f"target_mm,run,direction,{header}\n" + "\n".join(rows) + "\n")
    return path


@pytest.mark.parametrize("column", ["deviation_um", "actual_mm", "both"])
def test_iso230_finds_the_known_axis(tmp_path, column):
    up, down, reversal = _axis()
    s_up, s_down = K_UP * np.sqrt(2.5), K_DOWN * np.sqrt(2.5)
    assert (
        main(["iso230", str(_write(tmp_path / "run.csv", column)), "--out", str(tmp_path / "out")])
        == 0
    )
    r = json.loads((tmp_path / "out" / "iso230.json").read_text())
    a = r["axis"]
    tol = 1e-3 if column == "actual_mm" else 1e-6  # actual_mm is written to 1 nm
    assert (r["targets"], r["runs"], r["unit"]) == (9, 5, "um")
    assert a["B"] == pytest.approx(np.abs(reversal).max(), abs=tol)
    assert a["E_up"] == pytest.approx(np.ptp(up), abs=tol)
    assert a["E"] == pytest.approx(max(up.max(), down.max()) - min(up.min(), down.min()), abs=tol)
    assert a["M"] == pytest.approx(np.ptp((up + down) / 2), abs=tol)
    assert a["R_up"] == pytest.approx(4 * s_up, abs=tol)
    assert a["R"] == pytest.approx(np.max(2 * s_up + 2 * s_down + np.abs(reversal)), abs=tol)
    assert a["A"] == pytest.approx(
        max((up + 2 * s_up).max(), (down + 2 * s_down).max())
        - min((up - 2 * s_up).min(), (down - 2 * s_down).min()),
        abs=tol,
    )
    assert [row["target_mm"] for row in r["per_target"]] == pytest.approx(TARGETS)
    assert (tmp_path / "out" / "iso230.png").stat().st_size > 10_000


def _bad(capsys, tmp_path, text, fragment):
    (tmp_path / "bad.csv").write_text(text)
    assert main(["iso230", str(tmp_path / "bad.csv"), "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "Traceback" not in err and fragment in err
    assert not (tmp_path / "o" / "iso230.json").exists()


def test_iso230_bad_runs(capsys, tmp_path):
    head = "target_mm,run,direction,deviation_um\n"
    _bad(capsys, tmp_path, "target_mm,run,direction\n0,1,1\n", "deviation_um (or actual_mm)")
    _bad(capsys, tmp_path, head + "0,1,1,2\n0,2,1,3\n10,1,1,2\n10,2,1,2\n", "negative direction")
    _bad(capsys, tmp_path, head + "0,1,2,2\n", "direction is 2")
    one_run = "".join(f"{t},1,{d},1\n" for t in (0, 10) for d in (1, -1))
    _bad(capsys, tmp_path, head + one_run, "needs at least 2")
    copies = "".join(f"{t},{r},{d},1\n" for t in (0, 10) for r in (1, 2) for d in (1, -1))
    _bad(capsys, tmp_path, head + copies, "copies")
    uneven = copies + "0,3,1,1\n"
    _bad(capsys, tmp_path, head + uneven, "same number of runs")


def test_a_run_short_of_the_standard_s_five_runs_says_so(tmp_path, capsys, monkeypatch):
    """2 runs each way are evaluated ISO 230-2's way, but the printout, iso230.json and the
    figure's title say the standard asks for 5; a run of 5 conforms and says nothing of it."""
    import matplotlib.figure

    titles = []
    monkeypatch.setattr(
        matplotlib.figure.Figure,
        "savefig",
        lambda fig, *a, **k: titles.append(fig.axes[0].get_title()),
    )
    up, down, _ = _axis()
    rows = [
        f"{t:g},{j + 1},{d},{m + o:.6f}"
        for i, t in enumerate(TARGETS)
        for j, o in enumerate((-0.5, 0.5))
        for d, m in ((+1, up[i]), (-1, down[i]))
    ]
    (tmp_path / "two.csv").write_text("target_mm,run,direction,deviation_um\n" + "\n".join(rows))
    assert main(["iso230", str(tmp_path / "two.csv"), "--out", str(tmp_path / "two")]) == 0
    said = "ISO 230-2:2014 asks for at least 5 runs each way (this run has 2)"
    assert f"not conforming: {said}" in capsys.readouterr().out
    r = json.loads((tmp_path / "two" / "iso230.json").read_text())
    assert (r["runs"], r["conforms"], r["reason"]) == (2, False, said)
    assert f"NOT CONFORMING: {said}" in titles[-1]
    assert (
        main(["iso230", str(_write(tmp_path / "five.csv")), "--out", str(tmp_path / "five")]) == 0
    )
    assert "conforming" not in capsys.readouterr().out
    r = json.loads((tmp_path / "five" / "iso230.json").read_text())
    assert (r["runs"], r["conforms"], r["reason"]) == (5, True, None)
    assert "CONFORMING" not in titles[-1]


def test_the_standard_s_targets_follow_the_axis_length():
    """ISO 230-2:2014 5.3: at least five targets a metre and five in all up to 2 m, one every
    250 mm beyond: a 1.5 m axis with 6 targets falls short, with 8 it does not."""
    from calibench.scenarios.iso230 import nonconformity, targets_required

    assert [targets_required(s) for s in (300.0, 1000.0, 1500.0, 2000.0, 3000.0)] == [
        5,
        5,
        8,
        10,
        12,
    ]
    assert "8 target positions over its 1500 mm (this run has 6)" in nonconformity(
        np.linspace(0, 1500, 6), 5
    )
    assert nonconformity(np.linspace(0, 1500, 8), 5) is None
    assert nonconformity(np.linspace(0, 1000, 5), 5) is None
