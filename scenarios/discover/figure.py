"""discovery.png: each signal's residual before (the scene model alone) and after (with the
accepted effects), or the nominal twin's and the updated twin's replays side by side. The panels
are in-sample (fitted on every row) and say so; the title gives the held-out figures.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from calibench.estimators.discovery.fit import (
    lstsq,
)


def write_figure(path: Path, out: dict, fig: dict, before_fig: dict | None = None) -> None:
    """Residuals before (the scene model alone) and after (with the accepted effects); with
    ``before_fig`` (a replay by an updated twin), the nominal twin's residual and the updated
    twin's, both simulated (the scene model alone)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    sigs = fig["signals"]
    f, axes = plt.subplots(
        len(sigs), 2, figsize=(13, 3.6 * len(sigs)), squeeze=False, constrained_layout=True
    )

    def alone(sig):
        return sig.r - sig.base @ lstsq(sig.base, sig.r) if sig.base.shape[1] else sig.r

    # the panels show the fit on every row (in-sample); the held-out figures go in the title
    titles = ("scene model only, in-sample", "with the accepted effects, in-sample")
    for k, (row, s) in enumerate(zip(axes, sigs)):
        before = alone(s)
        after = fig["fitted"][s.axis]
        if before_fig is not None:
            before, after = alone(before_fig["signals"][k]), before
            titles = (
                "the nominal twin, replayed, in-sample",
                "the updated twin, replayed, in-sample",
            )
        if "x" in fig and s.u is not None:
            for ax, v, title in ((row[0], before, titles[0]), (row[1], after, titles[1])):
                lim = np.max(np.abs(before)) * 1000
                sc = ax.scatter(
                    fig["x"], fig["y"], c=v * 1000, s=6, cmap="coolwarm", vmin=-lim, vmax=lim
                )
                ax.set(
                    title=f"{s.name}: {title}, rms {np.sqrt(np.mean(v**2)) * 1000:.2f} um",
                    xlabel="x (mm)",
                    ylabel="y (mm)",
                )
                f.colorbar(sc, ax=ax, label="um")
        else:
            u, label = fig.get("abscissa") or (
                np.arange(len(before)),
                "row (posture x 3 + coordinate)",
            )
            for ax, v, title in ((row[0], before, titles[0]), (row[1], after, titles[1])):
                ax.plot(u, v * 1000, ".", ms=2)
                ax.set(
                    title=f"{s.name}: {title}, rms {np.sqrt(np.mean(v**2)) * 1000:.2f} um",
                    xlabel=label,
                    ylabel="um",
                )
    f.suptitle(
        f"{out['scenario']}: "
        + ("replayed with the updated twin; " if before_fig is not None else "")
        + (
            ", ".join(
                f"{e['name']} ({e['axis']})"
                + (" not confirmed" if e.get("status") == "not confirmed" else "")
                for e in out["effects"]
            )
            or _nothing_named(out)
        )
        + f"\nheld out ({out['holdout']}): {out['fit']['cv_rms_nominal'] * 1000:.1f} -> "
        f"{out['fit']['cv_rms_final'] * 1000:.1f} um; the panels: fitted on every row (in-sample)"
        + _left_said(out)
    )
    f.savefig(path, dpi=80)
    plt.close(f)


def _nothing_named(out: dict) -> str:
    """The title's words when no effect was named: "nothing missing" only where the verdict
    says so."""
    return (
        "nothing missing"
        if out.get("verdict", "").startswith("nothing missing")
        else ("no effect named")
    )


def _left_said(out: dict) -> str:
    """A title line for what is left unexplained (discovery.json's ``unexplained``), if any."""
    u = out.get("unexplained")
    if not u:
        return ""
    at = f", follows {u['driver']}" if u.get("driver") else ""
    return (
        f"\nunexplained: {u['rms'] * 1000:.1f} um held out against a noise floor of "
        f"{u['noise_floor'] * 1000:.1f} um{at}"
    )
