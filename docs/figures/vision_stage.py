"""The vision stage's blocks: the interferometer's deviations against the paper's, the circles
and the plate's alignment."""

from __future__ import annotations

from .engine import block
from .fmt import table
from .runner import SEED, checks, report

# the paper's largest positioning deviations (um): uncompensated, with its line rulers, with its
# cubic polynomial ("about 60 um", "about +-5 um", "about +-2 um")
PAPER_UNCOMPENSATED_UM = 60
PAPER_LINE_RULER_UM = 5
PAPER_POLYNOMIAL_UM = 2


@block(seconds=35, ci=True, last_digit=1)
def vision_stage():
    """calibench run vision-stage --seed 0 (render): the interferometer's largest deviations."""
    from calibench.sim.vision_stage import VisionStageTruth

    c, info = checks("vision-stage"), report("vision-stage")["info"]
    best = info["best_model"]
    injected = VisionStageTruth().x.pos.period
    return table(
        [
            "largest \\|positioning deviation\\| (interferometer, both axes)",
            "calibench",
            "the paper",
        ],
        [
            [
                "uncompensated",
                f"{c['pos_error_uncompensated_um']['value']:.1f} um",
                f"about {PAPER_UNCOMPENSATED_UM} um",
            ],
            [
                "line rulers, piecewise linear (Eq. 3-4)",
                f"{c['pos_error_lineruler_um']['value']:.1f} um",
                f"about +-{PAPER_LINE_RULER_UM} um",
            ],
            [
                "cubic bivariate polynomial (Eq. 5-9)",
                f"{c['pos_error_polynomial_um']['value']:.1f} um",
                f"about +-{PAPER_POLYNOMIAL_UM} um",
            ],
            [
                f"cross-validated model (here: X: {best['x']} ({injected:g} mm injected); "
                f"Y: {best['y']})",
                f"{c['pos_error_best_um']['value']:.1f} um",
                "",
            ],
        ],
    )


@block(seconds=35, ci=True, last_digit=1)
def vision_stage_alignment():
    """calibench run vision-stage --seed 0 (render): circle centres and the plate's alignment."""
    c, info = checks("vision-stage"), report("vision-stage")["info"]
    est, truth = info["phi_estimates_urad"], info["phi_truths_urad"]
    return (
        f"On seed {SEED}'s renders the circle centres are "
        f"{c['circle_centre_rms_px']['value']:.3f} px RMS from the exact image of the centre. "
        f"Plate angle: {est[0]:.0f} urad measured against {truth[0]:.0f} true, "
        f"{c['phi_residual_urad']['value']:.1f} urad left after {len(est) - 1} turns."
    )
