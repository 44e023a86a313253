"""``calibench fit``: the scenario's error model fitted to a stage recording (CONTRACT: fit.json)."""

from __future__ import annotations

import json
from pathlib import Path

from estimators.error_map import fit_quadratic
from scenarios.report import BadInput
from sim.recording import StageRecording, load_stage_csv


def fit_recording(scenario: str, model: str, recording: StageRecording) -> dict:
    """Per-axis fits of the error (measured - commanded) against the commanded position."""
    if model != "quadratic":
        raise BadInput(f"fit: model {model!r} is not implemented")
    axes = {}
    for axis, err in (("x", recording.x_err_mm), ("y", recording.y_err_mm)):
        try:
            f = fit_quadratic(recording.x_cmd_mm, recording.y_cmd_mm, err)
        except ValueError as e:
            raise BadInput(f"fit: axis {axis}: {e}") from None
        axes[axis] = f.as_dict()
    return {"scenario": scenario, "model": model, "axes": axes, "unit": "mm",
            "note": "rmse = sqrt(sse / (n - 6)); std are 1-sigma from the residuals"}


def run_fit(scenario: str, model: str, csv_path: Path, out_dir: Path) -> dict:
    result = fit_recording(scenario, model, load_stage_csv(csv_path))
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / "fit.json").write_text(json.dumps(result, indent=2) + "\n")
    return result
