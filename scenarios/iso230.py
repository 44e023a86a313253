"""``calibench iso230 RUN.csv``: the ISO 230-2:2014 evaluation of a user's own bidirectional run
of one axis (an interferometer's readings at m targets, n runs each way), the same evaluation the
vision stage's verification uses.

Writes DIR/iso230.json (docs/formats.md, "iso230") and DIR/iso230.png, the standard's plot: the mean
deviation at each target in each direction with its +-2s band, and the axis figures.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np

from calibench.estimators.stage import iso230_2
from calibench.recordings import RecordingError, load_axis_run
from calibench.scenarios.report import BadInput
from calibench.writing import replaced, write_text

PER_TARGET = (
    "mean_up",
    "mean_down",
    "mean_bi",
    "reversal_i",
    "s_up",
    "s_down",
    "R_up_i",
    "R_down_i",
    "R_i",
)


# ISO 230-2:2014's minimum set-up (its 5.3): five runs in each direction; on an axis up to 2 m at
# least five target positions a metre and five in all, on a longer one a target every 250 mm
RUNS_REQUIRED, TARGETS_REQUIRED = 5, 5


def targets_required(span_mm: float) -> int:
    """The target positions ISO 230-2:2014 asks for over a measured span of ``span_mm``."""
    if span_mm <= 2000.0:
        return max(TARGETS_REQUIRED, math.ceil(5.0 * span_mm / 1000.0 - 1e-9))
    return math.ceil(span_mm / 250.0 - 1e-9)


def nonconformity(targets_mm: np.ndarray, runs: int) -> str | None:
    """Why a run at ``targets_mm`` with ``runs`` runs each way is not the standard's test (the
    figures are still evaluated its way, on fewer readings), or None where it is.

    Parameters
    ----------
    targets_mm : (m,) array
        The run's target positions, mm.
    runs : int
        Its runs in each direction.

    Returns
    -------
    str or None
        The reason, in words, naming what the standard asks for and what the run has.
    """
    short = []
    if runs < RUNS_REQUIRED:
        short.append(f"{RUNS_REQUIRED} runs each way (this run has {runs})")
    span = float(np.ptp(targets_mm)) if len(targets_mm) else 0.0
    need = targets_required(span)
    if len(targets_mm) < need:
        short.append(
            f"{need} target positions over its {span:g} mm (this run has {len(targets_mm)})"
        )
    if not short:
        return None
    return f"ISO 230-2:2014 asks for at least {' and '.join(short)}"


def evaluate_run(path: Path) -> dict:
    """iso230.json's content for the run in ``path``."""
    run = load_axis_run(path)
    targets, up, down = run.tables()
    try:
        res = iso230_2.evaluate(targets, up, down)
    except ValueError as e:
        raise BadInput(f"{path}: {e}") from None
    if not (np.any(res.s_up > 0) or np.any(res.s_down > 0)):
        # identical runs carry no repeatability: say so rather than report R = 0
        raise BadInput(
            f"{path}: every run repeats the first one exactly: the repeatability (R, s) cannot be "
            "evaluated from copies"
        )
    why_not = nonconformity(np.asarray(targets, float), up.shape[1])
    return {
        "standard": "ISO 230-2:2014",
        # evaluated the standard's way whatever the run, but named its test only when it is one
        "conforms": why_not is None,
        "reason": why_not,
        "file": str(path),
        "unit": "um",
        "targets": int(len(targets)),
        "runs": int(up.shape[1]),
        "axis": res.as_dict(),
        "per_target": [
            {"target_mm": float(t), **{k: float(getattr(res, k)[i]) for k in PER_TARGET}}
            for i, t in enumerate(targets)
        ],
    }


def run_iso230(path: Path, out_dir: Path) -> dict:
    """The ``iso230`` command: evaluate, write DIR/iso230.json and DIR/iso230.png."""
    try:
        result = evaluate_run(path)
    except RecordingError as e:
        msg = str(e)
        raise BadInput(msg if str(path) in msg else f"{path}: {msg}") from None
    out_dir.mkdir(parents=True, exist_ok=True)
    write_text(out_dir / "iso230.json", json.dumps(result, indent=2) + "\n")
    with replaced(out_dir / "iso230.png") as tmp:
        figure(tmp, result)
    return result


def figure(path: Path, result: dict) -> None:
    """The standard's plot: mean deviations each way with their +-2s bands, and the figures."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = result["per_target"]
    t = np.array([r["target_mm"] for r in rows])
    fig, ax = plt.subplots(figsize=(8, 4.5), constrained_layout=True)
    for key, s_key, label, color, marker in (
        ("mean_up", "s_up", "approach +", "tab:blue", "^"),
        ("mean_down", "s_down", "approach -", "tab:red", "v"),
    ):
        m = np.array([r[key] for r in rows])
        s = np.array([r[s_key] for r in rows])
        ax.plot(t, m, marker=marker, color=color, label=f"mean deviation, {label}")
        ax.fill_between(t, m - 2 * s, m + 2 * s, color=color, alpha=0.15, label=f"+-2s, {label}")
    ax.axhline(0, color="k", lw=0.6)
    a = result["axis"]
    title = (
        f"ISO 230-2: A {a['A']:.2f}  E {a['E']:.2f}  M {a['M']:.2f}  R {a['R']:.2f}  B "
        f"{a['B']:.2f} um ({result['targets']} targets, {result['runs']} runs each way)"
    )
    if not result["conforms"]:  # the figures' label must not pass for the standard's test
        title += f"\nNOT CONFORMING: {result['reason']}"
    ax.set(xlabel="target position (mm)", ylabel="deviation, actual - target (um)", title=title)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.savefig(path, dpi=90)
    plt.close(fig)
