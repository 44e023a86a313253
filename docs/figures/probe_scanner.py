"""The probe scanner's blocks: the paper's method against least squares, the window m."""

from __future__ import annotations

from .engine import block
from .fmt import ranges, table
from .runner import checks, params, report

PAPER_M = (40, 60)  # the windows m with which the paper says its method meets the requirement


@block(seconds=5, ci=True)
def probe_scanner():
    """calibench run probe-scanner --seed 0: the paper's method against least squares."""
    from calibench.scenarios.registry import SCENARIOS

    p, c = params("probe-scanner"), checks("probe-scanner")
    samples = SCENARIOS["probe-scanner"].config().geometry.samples_per_turn

    def pm(name, fmt):
        return f"{p[name]['estimate']:{fmt}} +- {p[name]['std']:{fmt}}"

    return table(
        [
            "",
            f"d (truth {p['d_lsq']['truth']:.3f} mm)",
            f"dL ({p['dL_lsq']['truth']:.3f} mm)",
            f"alpha0 ({p['alpha0_lsq']['truth']:.1f} mrad)",
        ],
        [
            [
                f"paper's method, m = {c['paper_m']['value']:.0f}",
                f"{p['d_paper']['estimate']:.2f}",
                f"{p['dL_paper']['estimate']:.2f}",
                f"{p['alpha0_paper']['estimate']:.1f}",
            ],
            [
                f"least squares on all {samples} samples, with the plate centre",
                pm("d_lsq", ".4f"),
                pm("dL_lsq", ".4f"),
                pm("alpha0_lsq", ".2f"),
            ],
        ],
    )


@block(seconds=5, ci=True)
def probe_scanner_sweep():
    """calibench run probe-scanner --seed 0: the window m that meets the requirement, the rim."""
    from calibench.scenarios.registry import SCENARIOS

    config = SCENARIOS["probe-scanner"].config()
    info, c = report("probe-scanner")["info"], checks("probe-scanner")
    return (
        f"Over {config.sweep_turns} turns the paper's method meets the "
        f"{info['requirement_mm']:g} mm requirement for m = "
        f"{ranges(info['m_meeting_requirement_rms_over_turns'])} (the paper: about "
        f"{PAPER_M[0]}-{PAPER_M[1]}). The spectacle rim traced with the design values is "
        f"{c['contour_rms_before_mm']['value']:.2f} mm RMS off its true outline; with the "
        f"full-data calibration {c['contour_rms_after_mm']['value']:.4f} mm (half an encoder "
        f"step); with the paper's, {c['contour_rms_paper_mm']['value']:.3f} mm."
    )
