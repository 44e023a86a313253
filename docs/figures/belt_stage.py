"""The belt stage's blocks: its run against its limits, and the corners' accuracy on renders."""

from __future__ import annotations

from .engine import block
from .fmt import span, table
from .runner import checks, params, report

TILTS_RAD = (0.0, 0.2, 0.4, 0.6)  # the calibration board's tilts in corner-accuracy


@block(seconds=15, ci=True, last_digit=1)
def belt_stage():
    """calibench run belt-stage --seed 0 (render): the figures against their limits."""
    from calibench.scenarios.belt_stage.scenario import TOL_SIGMA

    c, p, info = checks("belt-stage"), params("belt-stage"), report("belt-stage")["info"]
    intr = [p[n] for n in ("fx", "fy", "cx", "cy")]
    off = max(abs(q["estimate"] - q["truth"]) for q in intr)
    tol = min(q["tolerance"] for q in intr)
    return table(
        ["figure", "value", "limit"],
        [
            [
                "corner_rms_px (detected vs exact projection, through the lens)",
                f"{c['corner_rms_px']['value']:.3f}",
                f"{c['corner_rms_px']['limit']:g}",
            ],
            [
                "map_rms_mm (estimated vs true map over the whole travel)",
                f"{c['map_rms_mm']['value']:.3f}",
                f"{c['map_rms_mm']['limit']:g}",
            ],
            [
                "check_rms_before_mm / check_rms_after_mm",
                f"{c['check_rms_before_mm']['value']:.2f} / {c['check_rms_after_mm']['value']:.3f}",
                f"- / {c['check_rms_after_mm']['limit']:g}",
            ],
            [
                "fx, fy, cx, cy against the truth",
                f"within {off:.3f} px (std {span([q['std'] for q in intr])})",
                f"{TOL_SIGMA:g} std, at least {tol:g} px",
            ],
            [
                "the paper's own travel method on the same images",
                f"map error {info['paper_method']['map_rms_mm']:.1f} mm",
                "",
            ],
        ],
    )


@block(seconds=8, ci=True)
def corner_accuracy():
    """Chessboard corners on MuJoCo renders of the belt stage's calibration board (its blur and
    sensor noise on), tilted 0 to 0.6 rad: the saddle refinement against OpenCV's classic pipeline
    (findChessboardCorners, then cornerSubPix in an 11 x 11 window) on the same images, both against
    the exact projection of the true corners."""
    from calibench.scenarios.belt_stage.corners import corner_rms_by_tilt

    rms = corner_rms_by_tilt(TILTS_RAD)
    return (
        f"On MuJoCo renders (blur and noise on, the board tilted {TILTS_RAD[0]:g} to "
        f"{TILTS_RAD[-1]:g} rad): {span(rms['ours'], '.3f')} px RMS, against "
        f"{span(rms['opencv'], '.3f')} px for OpenCV's cornerSubPix on the same images."
    )
