"""The figures of ``arm-cmm``: a run's residual per chosen posture (``arm_cmm.png``) and
``fit arm-cmm``'s error distributions (``fit.png``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from calibench.scenarios.arm_cmm import NAME
from calibench.scenarios.harness import FIGURE
from calibench.scenarios.progress import stage
from calibench.scenarios.report import Report


def posture_residuals(a: dict) -> tuple[np.ndarray, np.ndarray]:
    """Per chosen posture: |measured - modelled| tool point (mm), nominal and identified.

    Parameters
    ----------
    a : a run's artifacts: ``problem`` (the tracker problem), ``start`` (its nominal state),
        ``ident`` (the identification).

    Returns
    -------
    (before, after) : (n,) each, mm.
    """
    problem, st0, st = a["problem"], a["start"], a["ident"].state
    r, az, el = problem.meas.T
    y = np.stack([r * np.cos(el) * np.cos(az), r * np.cos(el) * np.sin(az), r * np.sin(el)], axis=1)
    return (
        np.linalg.norm(problem.points(st0) - y, axis=1),
        np.linalg.norm(problem.points(st) - y, axis=1),
    )


def write_figure(out_dir: Path, report: Report, artifacts: dict) -> None:
    """``out_dir/arm_cmm.png``: the residual per chosen posture, nominal and identified model
    (:func:`posture_residuals`)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out_dir.mkdir(parents=True, exist_ok=True)
    before, after = posture_residuals(artifacts)
    fig, ax = plt.subplots(figsize=(8, 4), constrained_layout=True)
    k = np.arange(1, len(before) + 1)
    ax.semilogy(k, before, "o", color="tab:red", label="nominal model")
    ax.semilogy(k, after, "o", color="tab:green", label="identified model")
    ax.set(
        xlabel="posture", ylabel="|measured - modelled| (mm)", title=f"{NAME}: residual per posture"
    )
    ax.legend()
    fig.savefig(out_dir / FIGURE, dpi=90)
    plt.close(fig)


def write_fit_figure(path: Path, result: dict, errors_mm: dict[str, np.ndarray]) -> None:
    """``fit arm-cmm``'s figure: the distribution of the 3-D errors of each set of rows.

    Parameters
    ----------
    path : the PNG to write.
    result : fit.json's content (its ``arm`` and ``model`` title the figure).
    errors_mm : {label: (n,) |measured - modelled| (mm)}: the training rows, each test, each
        held-out part.
    """
    stage(f"drawing {path.name}")  # matplotlib's import alone is seconds on a busy machine
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 4.5), constrained_layout=True)
    for label, d in errors_mm.items():
        x = np.sort(d)
        ax.plot(
            x,
            np.arange(1, len(x) + 1) / len(x),
            label=f"{label}: mean {d.mean():.3f}, max {d.max():.2f} mm",
        )
    ax.set(
        xlabel="3-D error |measured - modelled| (mm)",
        ylabel="fraction of postures",
        title=f"fit arm-cmm, {result['arm']}, model {result['model']}",
    )
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.savefig(path, dpi=90)
    plt.close(fig)
