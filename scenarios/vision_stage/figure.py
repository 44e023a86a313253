"""The ``vision-stage`` run's figure: the error field before and after, the interferometer lines."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from calibench.scenarios.harness import FIGURE
from calibench.scenarios.report import Report


def write_figure(out_dir: Path, report: Report, a: dict) -> None:
    """Write ``out_dir/vision_stage.png``: the error field before and after the cubic, and the
    interferometer's X lines with each compensation.

    Parameters
    ----------
    out_dir : the run's folder (made if missing).
    report : the run's report (not drawn: the artifacts hold what the figure shows).
    a : the run's artifacts: ``readings`` (n, 2) mm, ``err_um`` (n, 2), ``models`` (name ->
        readings (n, 2) mm -> error (n, 2) um) and ``verification`` (name -> interferometer lines).
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out_dir.mkdir(parents=True, exist_ok=True)
    r, e = a["readings"], a["err_um"]
    fig, axes = plt.subplots(1, 3, figsize=(16, 4.8), constrained_layout=True)
    after = e - a["models"]["polynomial"](r)
    for ax, field, title, scale in (
        (axes[0], e, "error field before (um)", 0.5),
        (axes[1], after, "after the cubic (um, x10)", 5.0),
    ):
        q = ax.quiver(
            r[:, 0],
            r[:, 1],
            field[:, 0],
            field[:, 1],
            np.hypot(*field.T),
            angles="xy",
            scale_units="xy",
            scale=1 / scale,
            cmap="viridis",
        )
        fig.colorbar(q, ax=ax, label="|error| (um)")
        ax.set(title=title, xlabel="X reading (mm)", ylabel="Y reading (mm)", aspect="equal")
    ax = axes[2]
    colors = {"lineruler": "tab:orange", "polynomial": "tab:green", "best": "tab:blue"}
    for name, lines in a["verification"].items():
        if name not in colors:
            continue
        for k, ln in enumerate(lines):
            if ln["axis"] != "x":
                continue
            mean = (ln["iso"].mean_up + ln["iso"].mean_down) / 2
            ax.plot(
                ln["targets_mm"],
                mean,
                "-o",
                ms=3,
                color=colors[name],
                label=name if k == 0 else None,
            )
    worst = max(
        float(np.max(np.abs(ln["iso"].mean_bi))) for ln in a["verification"]["uncompensated"]
    )
    ax.set(
        title=f"interferometer, X lines (uncompensated {worst:.0f} um)",
        xlabel="X target (mm)",
        ylabel="mean bidirectional deviation (um)",
    )
    ax.legend()
    fig.savefig(out_dir / FIGURE, dpi=90)
    plt.close(fig)
