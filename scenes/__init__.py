"""What the machines are: nominal geometry -> MJCF (+ texture assets), one module per scene.

``SCENES`` maps each scene's name to a function returning its default MJCF and assets. Each
imports its scene when called: importing one scene (a Monte-Carlo worker's) loads no other, and
not OpenCV, which only the camera scenes' textures need.
"""


def _belt_stage_default():
    from calibench.scenes import belt_stage

    return belt_stage.build_mjcf(belt_stage.BeltStageGeometry())


def _vision_stage_default():
    from calibench.scenes import vision_stage

    return vision_stage.build_mjcf(vision_stage.VisionStageGeometry())


def _probe_scanner_default():
    from calibench.scenes import probe_scanner

    n = probe_scanner.ProbeScannerNominal()
    return probe_scanner.build_mjcf(
        probe_scanner.ProbeScannerGeometry(), n.d_mm, n.dL_mm, n.alpha0_rad
    ), {}


def _arm(name: str, stiffness_nm_per_rad: float):
    """A built-in arm with its tracker, cones and a spring on every joint (its sag under gravity
    is what the steps settle)."""
    from calibench.scenes import arm_cmm, arm_mjcf

    arm = arm_cmm.load_arm(name)
    k = [stiffness_nm_per_rad] * arm.n_joints
    return arm_mjcf.build_mjcf(
        arm,
        None,
        None,
        k,
        (2.2, -0.9, 0.35),
        (1, 0, 0, 0),
        ((0.45, 0.25, -0.15), (0.45, -0.35, -0.15)),
    ), {}


def _stewart_default():
    from calibench.scenes import stewart

    g = stewart.StewartGeometry()
    return stewart.build_mjcf(
        g, g.base_hinges_mm, g.platform_hinges_mm, g.reflectors_mm, g.station_holes_mm
    ), {}


SCENES = {
    "belt-stage": _belt_stage_default,
    "vision-stage": _vision_stage_default,
    "probe-scanner": _probe_scanner_default,
    "arm-cmm": lambda: _arm("arm-cmm", 2e4),
    "arm-cmm/ur10": lambda: _arm("ur10", 2e5),
    "stewart": _stewart_default,
}
