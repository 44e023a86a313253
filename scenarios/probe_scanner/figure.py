"""The ``probe-scanner`` run's figure: the paper's d against m, one turn over the plate, the rim."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from calibench.scenarios.harness import FIGURE
from calibench.scenarios.report import Report


def write_figure(out_dir: Path, report: Report, a: dict) -> None:
    """Write ``out_dir/probe_scanner.png``: recovered d against m (the paper's study), rho(theta)
    with the fits at the minima, and the rim before and after calibration.

    Parameters
    ----------
    out_dir : the run's folder (made if missing).
    report : the run's report (not drawn: the artifacts hold what the figure shows).
    a : the run's artifacts: ``config``, ``ms`` (k,), ``sweep`` (k,) mm, ``rms_m`` (k,) mm,
        ``plate`` (the plate's scan), ``minima``, ``outline`` (n, 2) mm and ``contours``
        (name -> (n, 2) mm).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out_dir.mkdir(parents=True, exist_ok=True)
    cfg = a["config"]
    d_true, req = cfg.truth.d_mm, cfg.d_requirement_mm
    fig, axes = plt.subplots(1, 3, figsize=(16, 4.8), constrained_layout=True)
    ax = axes[0]
    ax.axhspan(
        d_true - req, d_true + req, color="tab:green", alpha=0.15, label=f"requirement +-{req:g} mm"
    )
    ax.axhline(d_true, color="k", lw=1, label="truth")
    ax.plot(a["ms"], a["sweep"], ".-", color="tab:blue", ms=3, label="this turn")
    ax.plot(
        a["ms"],
        d_true + a["rms_m"],
        "--",
        color="tab:red",
        label=f"truth + RMS error over {cfg.sweep_turns} turns",
    )
    ax.set(
        xlabel="samples per quadratic fit, m",
        ylabel="recovered d (mm)",
        ylim=(d_true - 4 * req, d_true + 4 * req),
        title="the paper's method: d against m",
    )
    ax.legend(fontsize=8)
    ax = axes[1]
    p = a["plate"]
    ax.plot(np.rad2deg(p.theta_rad), p.rho_mm, lw=0.8, color="tab:gray", label="rho")
    for f in a["minima"]:
        x = np.linspace(-0.25, 0.25, 50)
        ax.plot(
            np.rad2deg(f.theta_rad + x),
            f.rho_mm + 0.5 * f.curvature_mm * x * x,
            color="tab:orange",
            lw=1,
        )
        ax.plot(np.rad2deg(f.theta_rad), f.rho_mm, "o", color="tab:orange", ms=4)
    ax.set(
        xlabel="table angle (deg)",
        ylabel="rho (mm)",
        title=f"one turn over the plate; fits at m = {cfg.paper_m}",
    )
    ax = axes[2]
    o = a["outline"]
    ax.plot(o[:, 0], o[:, 1], color="k", lw=0.8, label="true rim")
    for k, c in (("before", "tab:red"), ("after", "tab:green")):
        ax.plot(*a["contours"][k].T, ".", ms=1, color=c, label=f"traced, {k}")
    ax.set(
        aspect="equal",
        xlabel="x (mm)",
        ylabel="y (mm)",
        title="the rim, before and after calibration",
    )
    ax.legend(fontsize=8, loc="upper right")
    fig.savefig(out_dir / FIGURE, dpi=90)
    plt.close(fig)
