"""What the machines are: nominal geometry -> MJCF (+ texture assets), one module per scene.

``SCENES`` maps each scene's name to a function returning its default MJCF and assets.
"""

from scenes import belt_stage, probe_scanner, vision_stage


def _belt_stage_default():
    return belt_stage.build_mjcf(belt_stage.BeltStageGeometry())


def _vision_stage_default():
    return vision_stage.build_mjcf(vision_stage.VisionStageGeometry())


def _probe_scanner_default():
    n = probe_scanner.ProbeScannerNominal()
    return probe_scanner.build_mjcf(probe_scanner.ProbeScannerGeometry(), n.d_mm, n.dL_mm, n.alpha0_rad), {}


SCENES = {
    "belt-stage": _belt_stage_default,
    "vision-stage": _vision_stage_default,
    "probe-scanner": _probe_scanner_default,
}
