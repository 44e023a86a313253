"""Stage and Stewart recordings: CSV round trip and one clear error per defect."""

import numpy as np
import pytest

from calibench.recordings import (
    RecordingError,
    StageRecording,
    StewartRecording,
    load_stage_csv,
    load_stewart_csv,
)


def test_csv_round_trip_keeps_optional_columns(tmp_path):
    rng = np.random.default_rng(9)
    x, y = rng.uniform(0, 900, 30), rng.uniform(0, 900, 30)
    rec = StageRecording(
        x_cmd_mm=x,
        y_cmd_mm=y,
        x_meas_mm=x + rng.normal(0, 0.05, 30),  # measured where commanded, to tens of um
        y_meas_mm=y + rng.normal(0, 0.05, 30),
        dir_x=np.sign(rng.normal(size=30)),
        run=np.repeat([0, 1, 2], 10),
    )
    rec.to_csv(tmp_path / "r.csv")
    back = load_stage_csv(tmp_path / "r.csv")
    for name in StageRecording.REQUIRED + ("dir_x", "run"):
        np.testing.assert_allclose(getattr(back, name), getattr(rec, name), rtol=1e-8)
    assert back.t_s is None and back.temp_c is None
    # nine significant digits of values below 1000 mm: each within 5e-7 mm, a difference 1e-6
    np.testing.assert_allclose(back.x_err_mm, rec.x_meas_mm - rec.x_cmd_mm, rtol=0, atol=1e-6)


def test_stewart_csv_round_trip_keeps_every_column(tmp_path):
    """Written with ten significant digits and read back: each leg's reading, the pose and the
    optional columns to that rounding (relative 5e-10; 1e-9 allowed), the directions exactly."""
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(4)
    n = 25
    rec = StewartRecording(
        readings_mm=rng.uniform(450, 650, (n, 6)),
        R=Rotation.from_rotvec(rng.normal(0, 0.05, (n, 3))).as_matrix(),
        t_mm=rng.uniform(-50, 50, (n, 3)) + [0, 0, 600],
        t_s=np.arange(n) * 3.0,
        temp_c=rng.uniform(19, 21, n),
        direction=rng.choice([-1.0, 0.0, 1.0], (n, 6)),
        load_n=rng.uniform(0, 200, n),
    )
    rec.to_csv(tmp_path / "p.csv")
    back = load_stewart_csv(tmp_path / "p.csv")
    for name in ("readings_mm", "t_mm", "t_s", "temp_c", "load_n"):
        np.testing.assert_allclose(getattr(back, name), getattr(rec, name), rtol=1e-9)
    np.testing.assert_allclose(back.R, rec.R, atol=1e-9)
    assert np.array_equal(back.direction, rec.direction)


@pytest.mark.parametrize(
    "text,message",
    [
        ("", "empty"),
        ("x_cmd_mm,y_cmd_mm,x_meas_mm,y_meas_mm\n", "no data rows"),
        ("x_cmd_mm,y_cmd_mm,x_meas_mm,y_meas_mm\n1,2,3,abc\n", "not a number"),
        ("x_cmd_mm,y_cmd_mm,x_meas_mm,y_meas_mm\n1,2,3\n", "not a number"),
        ("x_cmd_mm,y_cmd_mm,x_meas_mm,y_meas_mm\n1,2,3,inf\n", "not finite"),
        # a decimal comma in one cell: every value after it would move one column along
        (
            "x_cmd_mm,y_cmd_mm,x_meas_mm,y_meas_mm\n1,2,3,4\n1,2,3,4,5\n",
            "line 3: 5 values, the header names 4",
        ),
    ],
)
def test_defects_are_named(tmp_path, text, message):
    (tmp_path / "r.csv").write_text(text)
    with pytest.raises(RecordingError, match=message):
        load_stage_csv(tmp_path / "r.csv")


def test_trailing_empty_cells_are_harmless(tmp_path):
    """A spreadsheet's export may end rows with a separator: no value moves, so it is read."""
    (tmp_path / "r.csv").write_text("x_cmd_mm,y_cmd_mm,x_meas_mm,y_meas_mm\n1,2,3,4,\n5,6,7,8, ,\n")
    rec = load_stage_csv(tmp_path / "r.csv")
    np.testing.assert_array_equal(rec.y_meas_mm, [4.0, 8.0])


def test_the_shipped_sample_is_the_papers_two_tables_joined(real_data):
    """examples/belt_stage_paper.csv = the seed paper's X and Y error tables as one recording."""
    from pathlib import Path

    from calibench.recordings import load_stage_csv

    d = real_data / "seed_belt_stage"
    ex = np.loadtxt(d / "x_axis_error_mm.csv", delimiter=",", skiprows=1)
    ey = np.loadtxt(d / "y_axis_error_mm.csv", delimiter=",", skiprows=1)
    rec = load_stage_csv(Path(__file__).resolve().parents[1] / "examples" / "belt_stage_paper.csv")
    assert np.array_equal(rec.x_cmd_mm, ex[:, 0]) and np.array_equal(rec.y_cmd_mm, ex[:, 1])
    assert np.allclose(rec.x_err_mm, ex[:, 2], atol=5e-5) and np.allclose(
        rec.y_err_mm, ey[:, 2], atol=5e-5
    )


def test_an_arm_whose_joints_stay_within_six_degrees_is_read_in_degrees(tmp_path):
    """Readings within +-5 deg look like radians; an arm whose declared ranges are that narrow
    cannot tell them apart, so its file is read as the format says (degrees)."""
    from calibench.recordings import ArmRecording, load_arm_csv

    rng = np.random.default_rng(3)
    q = np.radians(rng.uniform(-5, 5, (40, 2)))
    ArmRecording(q, rng.uniform(-500, 500, (40, 3))).to_csv(tmp_path / "r.csv")
    with pytest.raises(RecordingError, match="radians"):
        load_arm_csv(tmp_path / "r.csv", 2)
    rec = load_arm_csv(tmp_path / "r.csv", 2, range_deg=np.array([[-5.0, 5.0], [-6.0, 6.0]]))
    np.testing.assert_allclose(rec.q_rad, q, rtol=1e-8)
