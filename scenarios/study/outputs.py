"""What a study writes from its finished trials: trials.parquet, summary.json, study.png and
study.rrd."""

from __future__ import annotations

import contextlib
import json
import math
import os
from pathlib import Path

import numpy as np

from calibench.scenarios.study.summary import checks_table, summary_table


@contextlib.contextmanager
def replaced(path: Path):
    """A temporary name beside ``path`` to write to, renamed over ``path`` when the block ends
    (an interrupted write leaves the old file whole; a symbolic link planted at ``path`` is
    replaced, not followed out of the folder). The temporary file goes if the block fails."""
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        yield tmp
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def write_outputs(out_dir: Path, rows: list[dict], summary: dict) -> None:
    """Write trials.parquet, summary.json, study.png (and study.rrd) for the finished trials.

    Parameters
    ----------
    out_dir : Path
        The study's folder.
    rows : list of dict
        The trials' journal rows, in trial order.
    summary : dict
        Their summary (:func:`~calibench.scenarios.study.summary.summarise`); without any
        parameter there is no figure and no recording.
    """
    import pyarrow as pa
    import pyarrow.parquet as pq

    keys = ["trial", "seed", "ok", "error", "elapsed_s"]
    cols = sorted(
        {
            k
            for r in rows
            for k in r
            if k not in keys and k != "traceback" and not k.endswith(".unit")
        }
    )
    table = {k: [r.get(k) for r in rows] for k in keys + cols}
    with replaced(out_dir / "trials.parquet") as tmp:
        pq.write_table(pa.table(table), tmp)
    with replaced(out_dir / "summary.json") as tmp:
        tmp.write_text(json.dumps(summary, indent=2) + "\n")
    if summary["parameters"]:
        _figure(out_dir, rows, summary)
        _log(out_dir, summary)


def _log(out_dir: Path, summary: dict) -> None:
    """study.rrd: the figure and the coverage table, for the rerun viewer."""
    from calibench.scenarios import rrlog

    rec = rrlog.open_recording(out_dir / "study.rrd", f"calibench-{summary['scenario']}-study")
    try:
        text = (
            f"# {summary['scenario']}: {summary['trials']} trials\n\n{summary_table(summary)}\n\n"
            f"{checks_table(summary)}"
        )
        rrlog.log_text(rec, "study/summary", text)
        rrlog.log_figure(rec, "study/figure", out_dir / "study.png")
    finally:
        rrlog.close(rec)


def _figure(out_dir: Path, rows: list[dict], summary: dict) -> None:
    """study.png: normalised errors against N(0, 1), and each parameter's coverage."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    good = [r for r in rows if r["ok"]]
    with_std = [p for p in summary["parameters"] if p["coverage_95"] is not None]
    # margins set by hand: the constrained layout measured every rotated name, a third of the time
    fig, axes = plt.subplots(1, 2, figsize=(14, 4.5))
    fig.subplots_adjust(left=0.05, right=0.99, top=0.93, bottom=0.25, wspace=0.15)
    ax = axes[0]
    z = [
        (r[f"{p['name']}.estimate"] - r[f"{p['name']}.truth"]) / r[f"{p['name']}.std"]
        for p in with_std
        for r in good
        if r.get(f"{p['name']}.std")
    ]
    if z:
        ax.hist(
            np.clip(z, -6, 6),
            bins=60,
            density=True,
            color="tab:blue",
            alpha=0.6,
            label="(estimate - truth) / std",
        )
        x = np.linspace(-6, 6, 200)
        ax.plot(x, np.exp(-x * x / 2) / math.sqrt(2 * math.pi), "k", label="N(0, 1): an honest std")
        ax.legend()
    ax.set(title=f"{summary['scenario']}: {len(good)} trials", xlabel="normalised error")
    ax = axes[1]
    names = [p["name"] for p in with_std]
    lo, hi = coverage_band(len(good))
    cover = [p["coverage_95"] for p in with_std]
    colours = ["tab:green" if lo <= c <= hi else "tab:red" for c in cover]
    ax.bar(range(len(names)), cover, color=colours)
    ax.axhspan(
        lo,
        hi,
        color="k",
        alpha=0.1,
        label=f"{lo:.2f}-{hi:.2f}: 0.95 within {len(good)} trials' scatter (red: outside)",
    )
    ax.set_xticks(range(len(names)), names, rotation=90, fontsize=7)
    ax.set(ylim=(0, 1.05), ylabel="coverage of +-1.96 std", title="coverage per parameter")
    ax.legend(loc="lower right")
    with replaced(out_dir / "study.png") as tmp:
        fig.savefig(tmp, dpi=90, format="png")
    plt.close(fig)


def coverage_band(trials: int) -> tuple[float, float]:
    """Where an honest std's coverage of 95 % intervals lands over ``trials`` trials: 0.95 within
    two binomial standard deviations."""
    half = 2 * math.sqrt(0.95 * 0.05 / max(trials, 1))
    return max(0.95 - half, 0.0), min(0.95 + half, 1.0)


def import_writers() -> None:
    """Load what :func:`write_outputs` needs while the workers run: on 2 cores a fast study's
    outputs would otherwise wait a second or two for these imports after its last trial."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot  # noqa: F401
    import pyarrow.parquet  # noqa: F401
    import scipy.special  # noqa: F401

    from calibench.scenarios import rrlog  # noqa: F401
