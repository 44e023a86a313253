"""Stage recordings: CSV round trip and one clear error per defect."""

import numpy as np
import pytest

from calibench.recordings import RecordingError, StageRecording, load_stage_csv


def test_csv_round_trip_keeps_optional_columns(tmp_path):
    rng = np.random.default_rng(9)
    rec = StageRecording(x_cmd_mm=rng.uniform(0, 900, 30), y_cmd_mm=rng.uniform(0, 900, 30),
                         x_meas_mm=rng.uniform(0, 900, 30), y_meas_mm=rng.uniform(0, 900, 30),
                         dir_x=np.sign(rng.normal(size=30)), run=np.repeat([0, 1, 2], 10))
    rec.to_csv(tmp_path / "r.csv")
    back = load_stage_csv(tmp_path / "r.csv")
    for name in StageRecording.REQUIRED + ("dir_x", "run"):
        np.testing.assert_allclose(getattr(back, name), getattr(rec, name), rtol=1e-8)
    assert back.t_s is None and back.temp_c is None
    np.testing.assert_allclose(back.x_err_mm, rec.x_meas_mm - rec.x_cmd_mm, rtol=1e-7)


@pytest.mark.parametrize("text,message", [
    ("", "empty"),
    ("x_cmd_mm,y_cmd_mm,x_meas_mm,y_meas_mm\n", "no data rows"),
    ("x_cmd_mm,y_cmd_mm,x_meas_mm,y_meas_mm\n1,2,3,abc\n", "not a number"),
    ("x_cmd_mm,y_cmd_mm,x_meas_mm,y_meas_mm\n1,2,3\n", "not a number"),
    ("x_cmd_mm,y_cmd_mm,x_meas_mm,y_meas_mm\n1,2,3,inf\n", "not finite"),
])
def test_defects_are_named(tmp_path, text, message):
    (tmp_path / "r.csv").write_text(text)
    with pytest.raises(RecordingError, match=message):
        load_stage_csv(tmp_path / "r.csv")
