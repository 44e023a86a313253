"""The ``belt-stage`` run's figure: both axes' error maps (truth, fit, stations) and the check
points."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from calibench.scenarios.harness import FIGURE
from calibench.scenarios.report import Report


def write_figure(out_dir: Path, report: Report, a: dict) -> None:
    """Write ``out_dir/error_map.png``: the measured station errors with the true and fitted maps
    of both axes, and the check points before and after compensation.

    Parameters
    ----------
    out_dir : the run's folder (made if missing).
    report : the run's report (not drawn: the artifacts hold what the figure shows).
    a : the run's artifacts: ``cmd`` (n, 2) mm, ``err`` (n, 2) mm, ``fits`` (the X and Y maps),
        ``truth``, ``geometry``, ``before`` and ``after`` (n_check, 2) mm, ``limit_mm``.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out_dir.mkdir(parents=True, exist_ok=True)
    cmd, err, (fx, fy), truth = a["cmd"], a["err"], a["fits"], a["truth"]
    g = a["geometry"]
    gx, gy = np.meshgrid(np.linspace(0, g.travel_mm[0], 61), np.linspace(0, g.travel_mm[1], 61))
    true = truth.error_mm(gx.ravel(), gy.ravel())
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.6), constrained_layout=True)
    for ax, k, fit, label in ((axes[0], 0, fx, "X"), (axes[1], 1, fy, "Y")):
        cs = ax.contourf(gx, gy, true[:, k].reshape(gx.shape), 20, cmap="viridis")
        ax.contour(gx, gy, fit(gx, gy), cs.levels[::2], colors="w", linewidths=0.7, linestyles="--")
        ax.scatter(
            cmd[:, 0], cmd[:, 1], c=err[:, k], cmap="viridis", norm=cs.norm, edgecolors="k", s=28
        )
        fig.colorbar(cs, ax=ax, label=f"{label} error (mm)")
        ax.set(
            title=f"{label} error: truth (fill), fit (dashed), stations (dots)",
            xlabel="X command (mm)",
            ylabel="Y command (mm)",
            aspect="equal",
        )
    b, af = np.linalg.norm(a["before"], axis=1), np.linalg.norm(a["after"], axis=1)
    ax = axes[2]
    point = np.arange(1, len(b) + 1)
    ax.semilogy(point, b, "o", color="tab:red", label="before compensation")
    ax.semilogy(point, af, "o", color="tab:green", label="after compensation")
    ax.axhline(a["limit_mm"], color="k", ls=":", label=f"limit {a['limit_mm']:g} mm")
    ax.set(
        title="check points (unseen by the fit)",
        xlabel="check point",
        ylabel="|position error| (mm)",
    )
    ax.legend(loc="center right")
    fig.savefig(out_dir / FIGURE, dpi=90)
    plt.close(fig)
