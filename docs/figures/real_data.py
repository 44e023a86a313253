"""Real data: calibench camera on OpenCV's and BoofCV's photos, the paper's belt-stage tables,
and the README's Python example on the UR10; beside that example, the sizes of the bad-input
and bad-config corpora docs/python.md cites."""

from __future__ import annotations

import json
import math

from .engine import ROOT, block
from .runner import DATA, calibench, need_data, scratch, series

# the boards of the photo sets, as `calibench camera` is told them
OPENCV_BOARD = {"cols": 9, "rows": 6, "square_mm": 25}
BOOFCV_BOARD = {"cols": 4, "rows": 6, "square_mm": 30}
OPENCV_FLAGS = ("--fix-aspect",)  # OpenCV's sample calibration fixes the aspect ratio
BOOFCV_FLAGS = ("--radial", 2, "--no-tangential")  # BoofCV's model: two radial terms
EXAMPLE_PARAMETER = "da2"  # what the README's Python example prints


def camera(folder: str, pattern: str, board: dict, *flags) -> dict:
    """``calibench camera`` on the photos ``DATA/folder/pattern``: its intrinsics.json."""
    out = scratch() / "camera" / folder
    images = sorted((DATA / folder).glob(pattern))
    need_data(DATA / folder)
    calibench(
        "camera",
        *images,
        "--cols",
        board["cols"],
        "--rows",
        board["rows"],
        "--square-mm",
        board["square_mm"],
        *flags,
        "--out",
        out,
    )
    return json.loads((out / "intrinsics.json").read_text())


@block(seconds=6, ci=True)
def real_data():
    """calibench camera on OpenCV's and BoofCV's photos, calibench fit belt-stage on the paper's
    tables (examples/belt_stage_paper.csv)."""
    import cv2
    import yaml

    cv = camera("opencv_left", "left*.jpg", OPENCV_BOARD, *OPENCV_FLAGS)
    ref = cv2.FileStorage(str(DATA / "opencv_left" / "left_intrinsics.yml"), cv2.FILE_STORAGE_READ)
    K0, rms0, n_cv = (
        ref.getNode("camera_matrix").mat(),
        ref.getNode("avg_reprojection_error").real(),
        len(cv["used"]),
    )
    K = cv["K"]
    bf = camera("boofcv_chess", "*.jpg", BOOFCV_BOARD, *BOOFCV_FLAGS)
    pin = yaml.safe_load((DATA / "boofcv_chess" / "intrinsic.yaml").read_text())["pinhole"]
    Kb = bf["K"]
    out = scratch() / "fit" / "belt-stage"
    calibench("fit", "belt-stage", ROOT / "examples" / "belt_stage_paper.csv", "--out", out)
    ax = json.loads((out / "fit.json").read_text())["axes"]
    x, y = ax["x"], ax["y"]
    b = OPENCV_BOARD
    cv_flags, bf_flags = " ".join(map(str, OPENCV_FLAGS)), " ".join(map(str, BOOFCV_FLAGS))
    return "\n".join(
        [
            f"- `calibench camera` on OpenCV's {n_cv} `left*.jpg` ({b['cols']}x{b['rows']}, "
            f"{b['square_mm']} mm, `{cv_flags}`): fx {K[0][0]:.1f} against the shipped "
            f"{K0[0, 0]:.1f} ({(K[0][0] / K0[0, 0] - 1) * 100:+.2f} %), principal point "
            f"{math.hypot(K[0][2] - K0[0, 2], K[1][2] - K0[1, 2]):.1f} px away, RMS "
            f"{cv['rms_px']:.2f} px (reference: {rms0:.2f} px).",
            f"- On BoofCV's chessboard set with BoofCV's model (`{bf_flags}`): fx {Kb[0][0]:.1f} / "
            f"fy {Kb[1][1]:.1f} against {pin['fx']:.1f} / {pin['fy']:.1f} "
            f"({(Kb[0][0] / pin['fx'] - 1) * 100:+.1f} %), principal point "
            f"{math.hypot(Kb[0][2] - pin['cx'], Kb[1][2] - pin['cy']):.1f} px away.",
            f"- `calibench fit belt-stage` on the paper's measured tables reproduces its Table 3 "
            f"to every printed digit (SSE {x['sse']:.2f} / {y['sse']:.2f} mm^2, R^2 "
            f"{x['r2']:.4f} / {y['r2']:.4f}, RMSE {x['rmse']:.4f} / {y['rmse']:.4f} mm).",
            "- `calibench fit vision-stage` fits the cubic of Eq. 5-9 (model `cubic`, "
            "coefficients a0..a9).",
        ]
    )


@block(seconds=3, ci=True)
def python_example():
    """The README's Python example's identification on ur10_D (calibench.estimators, no MuJoCo)."""
    from calibench.estimators.arm.point import PointProblem
    from calibench.estimators.identification.solver import identify_identifiable
    from calibench.recordings import load_arm_csv
    from calibench.scenarios.arm_cmm.arms import chain_of, load_arm

    rec = load_arm_csv(series("D")[0], n_joints=6)
    ident = identify_identifiable(PointProblem(chain_of(load_arm("ur10")), rec.q_rad, rec.xyz_mm))
    p = EXAMPLE_PARAMETER
    return (
        f"On ur10_D its second line prints "
        f"`{p} = {ident.estimate[p]:.3f} +- {ident.std[p]:.3f} mm`."
    )


@block(seconds=1, ci=True)
def test_corpora():
    """The bad-input corpus (tests/test_bad_input.py: the cases that must be refused, and the odd
    but legitimate ones that must be accepted) and the bad configs (tests/test_bad_config.py),
    counted from the tests themselves."""
    from calibench.scenarios.cli.status import EXIT_BAD_INPUT
    from tests import test_bad_config, test_bad_input

    cases = test_bad_input.CASES
    refused = sum(c[3] == EXIT_BAD_INPUT for c in cases)
    refused += sum(fragment is not None for _, fragment in test_bad_input.PHOTO_CASES)
    accepted = len(cases) + len(test_bad_input.PHOTO_CASES) - refused
    return (
        f"`tests/test_bad_input.py` holds {refused} bad inputs (and {accepted} odd but legitimate "
        f"ones, which must be accepted), `tests/test_bad_config.py` {len(test_bad_config.CASES)} "
        "configs that pass every type and sign check yet describe no workable set-up (a camera "
        "that cannot see the board over the travel, stations outside it, a Stewart platform whose "
        "legs leave their slides)."
    )
