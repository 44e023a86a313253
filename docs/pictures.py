"""Regenerate the README's pictures: ``python docs/pictures.py`` (writes docs/*.png)."""

from pathlib import Path

import sim  # noqa: F401  (sets MUJOCO_GL before mujoco is imported)
import cv2
import mujoco
import numpy as np

from estimators.chessboard import find_chessboard_corners
from scenes.belt_stage import BeltStageGeometry
from sim.belt_stage import BeltStageSim, BeltStageTruth

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


if __name__ == "__main__":
    main()
