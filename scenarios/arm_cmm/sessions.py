"""``calibench fit arm-cmm --leave-one-out``: what a user with a new set-up gets.

Each recording is a session (its own instrument frame, its own power-up). For each session in
turn the arm is calibrated on the others (:func:`calibench.scenarios.arm_cmm.fit.run_arm_fit`,
each training session with its own base registration), then the left-out session's frame is
registered on a share of its rows (``REGISTER_FRACTION``, fixed seed) and the calibration is
scored on the rest: the rows that score a session never chose, fitted or registered anything.
With ``--effects discover`` the discovery runs inside each fold, on the training sessions' rows
alone. Writes DIR/<session>/ (each fold's fit.json, residuals.csv, fit.png) and DIR/fit.json with
the table (``leave_one_out``).
"""

from __future__ import annotations

import json
from pathlib import Path

from calibench.scenarios.arm_cmm import NAME
from calibench.scenarios.arm_cmm.fit import REGISTER_FRACTION, SPLIT_SEED, run_arm_fit
from calibench.scenarios.progress import advance, expect, step
from calibench.scenarios.report import BadInput
from calibench.writing import write_text

FIGURES = ("samples", "mean_mm", "rms_mm", "p95_mm", "max_mm")


def leave_one_session_out(
    paths: list[Path],
    arm_spec: str | Path | None,
    model: str | None,
    out_dir: Path,
    effects: Path | str | None = None,
    register_on_scored: bool = False,
) -> dict:
    """Every session scored by a calibration on the others: fit.json's content (also written to
    ``out_dir``), with ``leave_one_out`` {session: its figures (mm), the sessions trained on,
    its frame's registration, and whether the score is in-sample}. ``register_on_scored``: each
    left-out session's frame and own terms fitted by least squares on the rows that score it
    (in-sample: the lowest RMS any registration of the others' calibration leaves there)."""
    if len(paths) < 2:
        raise BadInput(
            f"--leave-one-out: {len(paths)} recording; it needs at least two sessions, one to "
            "train on and one to score"
        )
    names = [Path(p).name for p in paths]
    if len(set(names)) != len(names):
        raise BadInput("--leave-one-out: two recordings share a file name; give each its own")
    table, folds = {}, {}
    # the folds' time so far says the rest's: not weighed by their training rows, which on the
    # UR10 did not follow it (the fold of 4,900 rows took 5 min, that of 15,000 rows 2.5 min:
    # the solve's iterations, not its rows, set its time)
    expect(len(paths), "folds")
    for k, left in enumerate(paths):
        train = [p for i, p in enumerate(paths) if i != k]
        fold_dir = out_dir / Path(left).stem
        step(f"{names[k]} left out")
        r = run_arm_fit(
            train, arm_spec, [], [left], None, model, fold_dir, effects, register_on_scored
        )
        advance()
        scored = r.get("test", {}).get(names[k]) or r["in_sample"][names[k]]
        table[names[k]] = {
            **{f: scored[f] for f in FIGURES},
            "trained_on": [Path(p).name for p in train],
            "frame": scored["frame"],
            "in_sample": names[k] in r.get("in_sample", {}),
        }
        folds[names[k]] = {"dir": str(fold_dir), "model": r["model"], "fit": r["fit"]}
        if "effects_from" in r:
            folds[names[k]]["effects_from"] = r["effects_from"]
    result = {
        "scenario": NAME,
        "arm": r["arm"],
        "model": r["model"],
        "leave_one_out": table,
        "folds": folds,
        "split": {"register_fraction": REGISTER_FRACTION, "seed": SPLIT_SEED},
    }
    out_dir.mkdir(parents=True, exist_ok=True)
    write_text(out_dir / "fit.json", json.dumps(result, indent=2) + "\n")
    return result
