"""What the machines are: nominal geometry -> MJCF (+ texture assets), one module per scene.

``SCENES`` maps each scene's name to a function returning its default MJCF and assets.
"""

from scenes import belt_stage, vision_stage


def _belt_stage_default():
    return belt_stage.build_mjcf(belt_stage.BeltStageGeometry())


def _vision_stage_default():
    return vision_stage.build_mjcf(vision_stage.VisionStageGeometry())


SCENES = {
    "belt-stage": _belt_stage_default,
    "vision-stage": _vision_stage_default,
}
