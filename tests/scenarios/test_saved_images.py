"""``run belt-stage --save-images``: the twin's rendered views with their truth, so that any
calibration tool can be tested on a camera of known intrinsics; calibench's own camera verb is
the first such tool."""

import dataclasses
import json

import numpy as np
import pytest

from calibench.scenarios.belt_stage.images import save_rendered_views
from calibench.scenarios.belt_stage.scenario import BeltStageConfig
from calibench.scenarios.cli import main

pytestmark = pytest.mark.render


def test_saved_views_calibrate_to_their_true_intrinsics(tmp_path, capsys):
    """The 20 tilted views (3 x 3 stations only, to keep it short) through `calibench camera`:
    fx, fy, cx, cy within 5 of their reported standard deviations of truth.json's camera, and
    each view's detected corners within 0.1 px of truth.json's exact projections."""
    config = dataclasses.replace(
        BeltStageConfig(), stations_x_mm=(0.0, 100.0, 200.0), stations_y_mm=(0.0, 100.0, 200.0)
    )
    truth = save_rendered_views(config, 0, tmp_path / "views")
    assert len(truth["corners_px"]) == config.n_intrinsic_views + 9
    on_disk = json.loads((tmp_path / "views" / "truth.json").read_text())
    assert on_disk["camera"]["K"] == truth["camera"]["K"]
    b = truth["board"]
    views = sorted(str(p) for p in (tmp_path / "views").glob("view*.png"))
    argv = ["camera", *views, "--cols", str(b["cols"]), "--rows", str(b["rows"])]
    argv += ["--square-mm", str(b["square_mm"]), "--out", str(tmp_path / "cam")]
    assert main(argv) == 0
    r = json.loads((tmp_path / "cam" / "intrinsics.json").read_text())
    K, K_true = np.array(r["K"]), np.array(truth["camera"]["K"])
    for name, (i, j) in {"fx": (0, 0), "fy": (1, 1), "cx": (0, 2), "cy": (1, 2)}.items():
        assert abs(K[i, j] - K_true[i, j]) < 5 * r["std"][name], name
    # the detector against the exact projections, on the first view
    import cv2

    from calibench.estimators.camera.chessboard import find_chessboard_corners

    img = cv2.imread(views[0], cv2.IMREAD_GRAYSCALE)
    found = find_chessboard_corners(img, b["cols"], b["rows"])
    exact = np.array(truth["corners_px"]["view00.png"])
    assert np.abs(found - exact).max() < 0.1


def test_save_images_is_for_the_belt_stage(tmp_path, capsys):
    argv = ["run", "stewart", "--no-rrd", "--out", str(tmp_path / "o")]
    assert main([*argv, "--save-images", str(tmp_path / "v")]) == 2
    assert "--save-images applies to belt-stage" in capsys.readouterr().err
