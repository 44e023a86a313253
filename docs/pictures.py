"""Regenerate the README's pictures: ``python docs/pictures.py`` (writes docs/*.png)."""

import os
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")  # before mujoco is imported: renders without a display

import cv2  # noqa: E402
import mujoco
import numpy as np

from calibench.estimators.camera.chessboard import find_chessboard_corners
from calibench.estimators.camera.circles import find_dark_circle
from calibench.scenes.belt_stage import BeltStageGeometry
from calibench.scenes.vision_stage import VisionStageGeometry
from calibench.sim.belt_stage import BeltStageSim, BeltStageTruth
from calibench.sim.vision_stage import VisionStageSim, VisionStageTruth

HERE = Path(__file__).parent


def main() -> None:
    g = BeltStageGeometry()
    s = BeltStageSim(g, BeltStageTruth())
    s.move(180_000, 60_000)
    # an oblique overview from a free camera
    r = mujoco.Renderer(s.model, 480, 640)
    cam = mujoco.MjvCamera()
    cam.lookat[:] = [0.4, 0.5, 0.75]
    cam.distance, cam.azimuth, cam.elevation = 4.2, -125, -22
    opt = mujoco.MjvOption()
    opt.geomgroup[3] = 0
    r.update_scene(s.data, camera=cam, scene_option=opt)
    overview = r.render()
    # what the overhead camera sees, with the detected corners
    img = s.render()
    corners = find_chessboard_corners(img, g.board.cols, g.board.rows)
    view = img.copy()
    for u, v in corners:
        cv2.circle(view, (int(round(u)), int(round(v))), 3, (40, 220, 90), -1, cv2.LINE_AA)
    cv2.imwrite(str(HERE / "belt_stage.png"), np.hstack([overview, view])[..., ::-1])
    s.close()
    vision_stage()


def vision_stage() -> None:
    """The microscope's view of a circle near the image centre, with the detected centre."""
    g = VisionStageGeometry()
    s = VisionStageSim(g, VisionStageTruth(), np.random.default_rng(0))
    s.move(7.02, 8.98)
    img = s.render(noise_dn=2.0, psf_px=1.0)
    fit = find_dark_circle(img)
    view = img.copy()
    c = tuple(int(round(x)) for x in fit.centre)
    cv2.drawMarker(view, c, (40, 220, 90), cv2.MARKER_CROSS, 40, 2, cv2.LINE_AA)
    cv2.circle(view, c, int(round(fit.radius_px)), (40, 220, 90), 1, cv2.LINE_AA)
    cv2.drawMarker(view, (384, 288), (230, 60, 50), cv2.MARKER_TILTED_CROSS, 20, 1, cv2.LINE_AA)
    cv2.imwrite(str(HERE / "vision_stage_microscope.png"), view[..., ::-1])
    s.close()


if __name__ == "__main__":
    main()
