"""The command line: contract outputs, the real-data figures, and bad input (one line, exit 2)."""

import json
import shutil

import numpy as np
import pytest

from calibench.scenarios.cli import main


def _bad(capsys, argv, fragment):
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "Traceback" not in err
    assert fragment in err
    return err


def test_bad_input_exits_2_with_one_line(capsys, tmp_path):
    _bad(capsys, ["run", "no-such-scenario"], "unknown scenario")
    _bad(capsys, ["fit", "belt-stage", str(tmp_path / "missing.csv")], "cannot read")
    _bad(
        capsys,
        ["run", "belt-stage", "--config", str(tmp_path / "missing.toml")],
        "cannot read config",
    )
    (tmp_path / "bad.toml").write_text("this is = = not toml")
    _bad(capsys, ["run", "belt-stage", "--config", str(tmp_path / "bad.toml")], "not valid TOML")
    (tmp_path / "key.toml").write_text("[belt-stage]\nno_such_key = 3\n")
    _bad(capsys, ["run", "belt-stage", "--config", str(tmp_path / "key.toml")], "unknown key")
    (tmp_path / "type.toml").write_text("[belt-stage.truth]\nboard_yaw_rad = 'big'\n")
    _bad(capsys, ["run", "belt-stage", "--config", str(tmp_path / "type.toml")], "must be a number")
    (tmp_path / "c0.toml").write_text("[belt-stage.truth]\nerror_x = [1, 0, 0, 0, 0, 0]\n")
    _bad(capsys, ["run", "belt-stage", "--config", str(tmp_path / "c0.toml")], "homed")
    (tmp_path / "nocol.csv").write_text("x_cmd_mm,y_cmd_mm,x_meas_mm\n1,2,3\n")
    _bad(capsys, ["fit", "belt-stage", str(tmp_path / "nocol.csv")], "missing column(s) y_meas_mm")
    (tmp_path / "nan.csv").write_text("x_cmd_mm,y_cmd_mm,x_meas_mm,y_meas_mm\n1,2,3,nan\n")
    _bad(capsys, ["fit", "belt-stage", str(tmp_path / "nan.csv")], "not finite")
    (tmp_path / "line.csv").write_text(
        "x_cmd_mm,y_cmd_mm,x_meas_mm,y_meas_mm\n" + "".join(f"{x},0,{x},0\n" for x in range(20))
    )
    _bad(capsys, ["fit", "belt-stage", str(tmp_path / "line.csv")], "degenerate")
    _bad(
        capsys,
        ["camera", str(tmp_path / "none.jpg"), "--cols", "9", "--rows", "6", "--square-mm", "25"],
        "no such image",
    )
    assert main(["run"]) == 2  # argparse, in one line
    assert "\n" not in capsys.readouterr().err.strip()


def test_config_overrides_reach_the_run(tmp_path):
    (tmp_path / "c.toml").write_text(
        "[belt-stage]\nn_intrinsic_views = 15\n[belt-stage.truth]\nboard_yaw_rad = -0.002\n"
    )
    out = tmp_path / "out"
    status = main(
        [
            "run",
            "all",
            "--fidelity",
            "analytic",
            "--no-rrd",
            "--config",
            str(tmp_path / "c.toml"),
            "--out",
            str(out),
        ]
    )
    rep = json.loads((out / "belt-stage" / "report.json").read_text())
    assert status == 0 and "rrd" not in rep
    yaw = next(p for p in rep["parameters"] if p["name"] == "board_yaw_mrad")
    assert yaw["truth"] == pytest.approx(-2.0)
    assert rep["info"]["intrinsic_views_used"] == 15


def test_fit_reproduces_the_papers_table_3(real_data, tmp_path):
    d = real_data / "seed_belt_stage"
    ex = np.loadtxt(d / "x_axis_error_mm.csv", delimiter=",", skiprows=1)
    ey = np.loadtxt(d / "y_axis_error_mm.csv", delimiter=",", skiprows=1)
    rows = ["x_cmd_mm,y_cmd_mm,x_meas_mm,y_meas_mm"]
    rows += [f"{x:g},{y:g},{x + a:.4f},{y + b:.4f}" for (x, y, a), (_, _, b) in zip(ex, ey[:, :3])]
    (tmp_path / "paper.csv").write_text("\n".join(rows) + "\n")
    assert main(["fit", "belt-stage", str(tmp_path / "paper.csv"), "--out", str(tmp_path)]) == 0
    fit = json.loads((tmp_path / "fit.json").read_text())
    assert fit["model"] == "quadratic" and fit["unit"] == "mm"
    table3 = {"x": (31.96, 0.9749, 0.5272), "y": (24.08, 0.9833, 0.4576)}
    for axis, (sse, r2, rmse) in table3.items():
        a = fit["axes"][axis]
        assert (round(a["sse"], 2), round(a["r2"], 4), round(a["rmse"], 4)) == (sse, r2, rmse)
        assert set(a["coef"]) == {"c0", "c1", "c2", "c3", "c4", "c5"}


def test_camera_on_opencv_left_meets_the_reference(real_data, tmp_path):
    """OpenCV's sample: fx = fy = 535.916, (cx, cy) = (342.283, 235.571), RMS 0.393 px."""
    images = sorted((real_data / "opencv_left").glob("*.jpg"))
    # a photo without this board is listed as rejected, not fatal
    shutil.copy(real_data / "boofcv_circles" / "image00000.jpg", tmp_path / "circles.jpg")
    argv = [str(p) for p in images + [tmp_path / "circles.jpg"]]
    assert (
        main(
            [
                "camera",
                *argv,
                "--cols",
                "9",
                "--rows",
                "6",
                "--square-mm",
                "25",
                "--fix-aspect",
                "--out",
                str(tmp_path),
            ]
        )
        == 0
    )
    r = json.loads((tmp_path / "intrinsics.json").read_text())
    K = np.array(r["K"])
    # not our std (0.4 px) but the corner detector's own spread: OpenCV's pipeline on these
    # photos with cornerSubPix's 5 x 5 window (benchmarks/opencv_classic.py) gives fx 532.8, the
    # shipped reference 535.9; the detectors differ by 0.6 % in fx and a few px in the centre
    assert abs(K[0, 0] / 535.916 - 1) < 0.01 and K[0, 0] == pytest.approx(K[1, 1])
    assert np.hypot(K[0, 2] - 342.283, K[1, 2] - 235.571) < 3
    assert r["rms_px"] < 0.5
    assert r["image_size"] == [640, 480] and len(r["dist"]) == 5
    assert len(r["used"]) == 13 and "circles.jpg" in r["rejected"]
    assert set(r["per_view_rms_px"]) == set(r["used"])
    assert {"fx", "fy", "cx", "cy"} <= set(r["std"])
    assert r["corners_left_out"] == {}  # no gross corner in OpenCV's sample
    assert list(r["distortion"]) == ["k1", "k2", "p1", "p2", "k3"]
    assert list(r["distortion"].values()) == r["dist"]
    # OpenCV's sample keeps the board in the image's middle: its edges are never reached
    assert 0.3 < r["corner_coverage"] < 0.9
    assert (tmp_path / "camera.png").stat().st_size > 10_000


def test_corner_coverage_counts_the_cells_the_board_reached():
    from calibench.scenarios.camera_figure import COVERAGE_GRID, coverage

    size = (640, 480)
    step = np.array(size) / COVERAGE_GRID
    centres = (np.indices((COVERAGE_GRID, COVERAGE_GRID)).reshape(2, -1).T + 0.5) * step
    assert coverage({"all": centres}, size) == 1.0
    one = {"a": np.full((54, 2), 10.0), "b": np.array([[np.nan, np.nan], [700.0, 10.0]])}
    assert coverage(one, size) == 1 / COVERAGE_GRID**2  # NaN and outside the image not counted


def test_a_calibration_that_does_not_converge_says_what_to_change(real_data, monkeypatch):
    import calibench.scenarios.camera as cam
    from calibench.errors import BadInput
    from calibench.estimators.camera.zhang import CalibrationError

    def wanders(*args, **kwargs):
        raise CalibrationError("the calibration did not converge in 100 iterations")

    monkeypatch.setattr(cam, "calibrate_camera", wanders)
    photos = sorted((real_data / "opencv_left").glob("left*.jpg"))
    with pytest.raises(BadInput, match="tilt the board .*--radial 2, --no-tangential"):
        cam.calibrate_photos(photos, 9, 6, 25.0)


def test_camera_leaves_out_a_gross_corner_and_says_which(real_data, tmp_path, monkeypatch):
    """A detector's 9.2 px error on one corner of one photo (the size the sector detector made
    on a steep real view): the corner is named and left out, the other 53 of that photo kept,
    and the calibration is the clean photos' to a twentieth of its std (one corner of 702 left
    out); kept in, it raises the RMS by over 0.05 px and moves the calibration by over half a
    std."""
    import calibench.scenarios.camera as cam

    real = cam.find_chessboard_corners

    def one_gross(img, cols, rows):
        c = real(img, cols, rows)
        if img.shape == (480, 640) and abs(float(c[0, 0]) - first[0]) < 1e-9:
            c = c.copy()
            c[20] += [9.2, 0.0]
        return c

    images = sorted((real_data / "opencv_left").glob("*.jpg"))
    first = real(__import__("cv2").imread(str(images[0]), 0), 9, 6)[0]
    args = [
        "camera",
        *map(str, images),
        "--cols",
        "9",
        "--rows",
        "6",
        "--square-mm",
        "25",
        "--fix-aspect",
    ]
    assert main(args + ["--out", str(tmp_path / "clean")]) == 0
    clean = json.loads((tmp_path / "clean" / "intrinsics.json").read_text())
    monkeypatch.setattr(cam, "find_chessboard_corners", one_gross)
    assert main(args + ["--out", str(tmp_path)]) == 0
    r = json.loads((tmp_path / "intrinsics.json").read_text())
    assert [c["corner"] for c in r["corners_left_out"][images[0].name]] == [20]
    assert len(r["corners_left_out"]) == 1

    def shift(res):  # the largest move of fx, cx, cy from the clean photos', in their std
        K, Kc = np.array(res["K"]), np.array(clean["K"])
        moved = [K[0, 0] - Kc[0, 0], K[0, 2] - Kc[0, 2], K[1, 2] - Kc[1, 2]]
        return max(abs(m) / clean["std"][k] for m, k in zip(moved, ("fx", "cx", "cy")))

    assert shift(r) < 0.05 and r["rms_px"] < 0.5
    monkeypatch.setattr(cam, "gross_corners", lambda *a, **k: [])
    assert main(args + ["--out", str(tmp_path / "kept")]) == 0
    kept = json.loads((tmp_path / "kept" / "intrinsics.json").read_text())
    assert kept["rms_px"] > r["rms_px"] + 0.05 and shift(kept) > 0.5


def test_camera_on_boofcv_chess_meets_the_reference(real_data, tmp_path):
    """BoofCV's own result (its model: 2 radial terms, no tangential): fx 701.01, fy 698.65,
    cx 308.46, cy 246.84."""
    images = sorted((real_data / "boofcv_chess").glob("*.jpg"))
    assert (
        main(
            [
                "camera",
                *map(str, images),
                "--cols",
                "4",
                "--rows",
                "6",
                "--square-mm",
                "30",
                "--radial",
                "2",
                "--no-tangential",
                "--out",
                str(tmp_path),
            ]
        )
        == 0
    )
    r = json.loads((tmp_path / "intrinsics.json").read_text())
    K = np.array(r["K"])
    assert abs(K[0, 0] / 701.01 - 1) < 0.01 and abs(K[1, 1] / 698.65 - 1) < 0.01
    assert np.hypot(K[0, 2] - 308.46, K[1, 2] - 246.84) < 3
    assert r["rms_px"] < 0.5
    assert r["dist"][2:] == [0.0, 0.0, 0.0]


def test_version_and_internal_errors(tmp_path, capsys, monkeypatch):
    """--version answers; a defect (here: an estimator that raises) is exit 3, one line, and the
    traceback in OUT/error.log."""
    import calibench

    assert main(["--version"]) == 0  # argparse's exit, turned into main's status
    assert calibench.__version__ in capsys.readouterr().out
    from calibench.scenarios.arm_cmm import fit as arm_fit

    def broken(*a, **k):
        raise RuntimeError("a defect")

    monkeypatch.setattr(arm_fit, "run_arm_fit", broken)
    assert main(["fit", "arm-cmm", "x.csv", "--out", str(tmp_path)]) == 3
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "internal error" in err and "RuntimeError" in err
    assert "Traceback" in (tmp_path / "error.log").read_text()


def test_the_command_ends_with_main_s_status_and_its_output_whole(tmp_path):
    """The executable skips the interpreter's teardown (entry.command): the status is still
    main's, what it printed to a pipe is all there (the help in full, bad input's one line), and
    a study's outputs are written and closed (its recording too)."""
    import subprocess
    import sys

    import pyarrow.parquet as pq

    from calibench.scenarios.cli.parser import build_parser

    cli = [sys.executable, "-m", "calibench.scenarios.cli"]
    shown = subprocess.run([*cli, "--help"], capture_output=True, text=True)
    assert shown.returncode == 0
    assert shown.stdout == build_parser().format_help()
    bad = subprocess.run([*cli, "run", "no-such-scenario"], capture_output=True, text=True)
    assert bad.returncode == 2 and bad.stdout == ""
    assert len(bad.stderr.splitlines()) == 1 and "unknown scenario" in bad.stderr
    out = tmp_path / "study"
    done = subprocess.run(
        [*cli, "montecarlo", "arm-cmm", "--trials", "6", "--out", str(out)],
        capture_output=True,
        text=True,
    )
    assert done.returncode == 0, done.stderr
    assert "arm-cmm" in done.stdout  # the coverage table, printed last
    assert pq.read_table(out / "trials.parquet").num_rows == 6
    assert json.loads((out / "summary.json").read_text())["trials"] == 6
    assert (out / "study.rrd").stat().st_size > 0


def test_the_command_under_a_profiler_exits_as_usual():
    """A tracer's or profiler's exit handler, registered before the command's, still runs (it
    writes the coverage or profile); without one the command's handler ends the process first."""
    import subprocess
    import sys

    def ran(watched: bool) -> str:
        code = (
            "import atexit, sys\n"
            "atexit.register(print, 'the earlier handler ran')\n"
            + ("sys.setprofile(lambda *a: None)\n" if watched else "")
            + "sys.argv = ['calibench', 'run', 'no-such-scenario']\n"
            "from calibench.scenarios.cli import command\n"
            "command()\n"
        )
        done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
        assert done.returncode == 2 and "unknown scenario" in done.stderr
        return done.stdout

    assert ran(watched=True) == "the earlier handler ran\n"
    assert ran(watched=False) == ""


def test_a_run_without_its_recording_removes_a_former_one(tmp_path):
    """``--no-rrd`` into a folder where a run wrote run.rrd before: the old recording does not
    stay beside the new report, which names none."""
    assert main(["run", "stewart", "--out", str(tmp_path)]) == 0
    assert (tmp_path / "run.rrd").exists()
    assert main(["run", "stewart", "--no-rrd", "--out", str(tmp_path)]) == 0
    assert not (tmp_path / "run.rrd").exists()
    assert "rrd" not in json.loads((tmp_path / "report.json").read_text())


@pytest.mark.parametrize(
    ("verb", "former"),
    [
        ("run", "a run's own former results"),
        ("fit", "a former fit's"),
        ("discover", "a former discovery's"),
        ("camera", "a former calibration's"),
        ("iso230", "a former evaluation's"),
        ("acceptance", "a former test's"),
        ("montecarlo", "the study starts anew"),
        ("uncertainty", "the study starts anew"),
    ],
)
def test_each_verb_s_help_says_what_its_force_does(verb, former, capsys):
    """--force's help is the verb's own: a study's "starts anew" only where there is a study."""
    assert main([verb, "--help"]) == 0
    text = " ".join(capsys.readouterr().out.split())  # argparse's wrapping undone
    force = text[text.index("--force ") :]
    assert former in force
    assert ("starts anew" in force) == (verb in ("montecarlo", "uncertainty"))


@pytest.mark.parametrize("failing", [(), ("probe-scanner", "stewart")])
def test_run_all_ends_with_one_overall_verdict(failing, tmp_path, monkeypatch, capsys):
    """`run all`'s last line is its verdict, and agrees with its exit status (each scenario's
    run replaced by one whose check passes or fails, as ``failing`` says)."""
    import dataclasses

    from calibench.scenarios import registry
    from calibench.scenarios.report import Check, Report

    real = registry.scenario

    def scenario(name):
        def run(config, seed, fidelity, out_dir, rrd):
            return Report(
                name, seed, fidelity, checks=[Check("c", 2.0 if name in failing else 0.0, 1.0)]
            )

        return dataclasses.replace(real(name), run=run)

    monkeypatch.setattr(registry, "scenario", scenario)
    status = main(["run", "all", "--fidelity", "analytic", "--no-rrd", "--out", str(tmp_path)])
    last = capsys.readouterr().out.strip().splitlines()[-1]
    n = len(registry.NAMES)
    if failing:
        assert status == 1
        assert last == f"2 of {n} scenarios failed: probe-scanner, stewart"
    else:
        assert status == 0
        assert last == f"all {n} scenarios passed"


def test_camera_refuses_a_part_of_the_board_and_names_its_size(real_data, tmp_path, capsys):
    """OpenCV's 9 x 6 board asked for as 7 x 6: the detector finds a 7 x 6 part of it, which a
    calibration would take for the whole; refused in one line naming the board's size."""
    photos = [str(real_data / "opencv_left" / f"left0{k}.jpg") for k in (1, 2, 6, 7)]
    argv = ["camera", *photos, "--square-mm", "25", "--out", str(tmp_path)]
    assert main([*argv, "--cols", "7", "--rows", "6"]) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "more inner corners than --cols 7 --rows 6" in err
    assert "seems to have 9x6: give --cols 9 --rows 6" in err
    assert not (tmp_path / "intrinsics.json").exists()
    assert main([*argv, "--cols", "9", "--rows", "6"]) == 0  # the whole board: calibrated
    # BoofCV's 4 x 6 board asked for as 3 x 6: the sector detector returns a grid that steps
    # over one line of corners
    photos = [str(real_data / "boofcv_chess" / f"frame0{k}.jpg") for k in (1, 2, 3, 4)]
    argv = ["camera", *photos, "--square-mm", "30", "--out", str(tmp_path / "b")]
    assert main([*argv, "--cols", "3", "--rows", "6"]) == 2
    assert "seems to have 4x6: give --cols 4 --rows 6" in capsys.readouterr().err
