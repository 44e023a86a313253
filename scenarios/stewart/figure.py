"""The ``stewart`` run's figure: held-out poses before and after calibration, and the one-step
calibration's errors in units of their std."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from calibench.scenarios.harness import FIGURE
from calibench.scenarios.report import Report
from calibench.scenarios.stewart import NAME


def write_figure(out_dir: Path, report: Report, artifacts: dict) -> None:
    """``out_dir/stewart.png``: the held-out poses' error per pose before and after calibration
    (``artifacts["holdout_error_mm"]``: {"before", "after", "two_step"}: (n, 6) mm at the six
    hinges), and every leg parameter's error in units of its reported std (a calibration whose
    std are honest keeps them in +-3)."""
    err = artifacts["holdout_error_mm"]
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out_dir.mkdir(parents=True, exist_ok=True)
    fig, (a, b) = plt.subplots(1, 2, figsize=(12, 4.2), constrained_layout=True)
    k = np.arange(1, len(err["before"]) + 1)
    for key, color, label in (
        ("before", "tab:red", "nominal"),
        ("after", "tab:green", "one-step calibration"),
        ("two_step", "tab:blue", "two-step calibration"),
    ):
        rms_um = np.sqrt(np.mean(np.square(err[key]), axis=1)) * 1000
        a.semilogy(
            k, rms_um, "o", color=color, label=f"{label}: rms {np.sqrt(np.mean(rms_um**2)):.3g} um"
        )
    a.set(
        xlabel="held-out pose",
        ylabel="hinge-point error, rms over the six (um)",
        title=f"{NAME}: held-out poses",
    )
    a.legend(fontsize=8)
    # a parameter without a std (none of the platform's) has no bar
    z = np.array(
        [(p.estimate - p.truth) / (np.nan if p.std is None else p.std) for p in report.parameters]
    )
    b.bar(np.arange(len(z)), z, color=np.where(np.abs(z) <= 3, "tab:green", "tab:red"))
    b.axhspan(-3, 3, color="0.9", zorder=0)
    b.set(
        xlabel="leg parameter (7 per leg: r, B, l)",
        ylabel="(estimate - truth) / std",
        title="one-step calibration: error in units of its std",
    )
    fig.savefig(out_dir / FIGURE, dpi=90)
    plt.close(fig)
