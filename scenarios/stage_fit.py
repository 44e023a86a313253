"""``calibench fit``: the scenario's error model fitted to a stage recording (docs/formats.md:
fit.json)."""

from __future__ import annotations

import json
from pathlib import Path

from calibench.estimators.stage.error_map import fit_cubic, fit_quadratic
from calibench.recordings import StageRecording, load_stage_csv
from calibench.scenarios.report import BadInput
from calibench.writing import write_text

N_COEF = {"quadratic": 6, "cubic": 10}


def fit_recording(scenario: str, model: str, recording: StageRecording) -> dict:
    """Per-axis fits of the error (measured - commanded) against the commanded position.

    ``quadratic``: the belt-stage seed's Eq. 1 (c0..c5); ``cubic``: the vision-stage seed's
    Eq. 5-9 (a0..a9 on 1, x, y, x^2, xy, y^2, x^3, x^2 y, x y^2, y^3).
    """
    if model not in N_COEF:
        raise BadInput(f"fit: model {model!r} is not implemented")
    axes = {}
    x, y = recording.x_cmd_mm, recording.y_cmd_mm
    for axis, err in (("x", recording.x_err_mm), ("y", recording.y_err_mm)):
        try:
            if model == "quadratic":
                axes[axis] = fit_quadratic(x, y, err).as_dict()
            else:
                axes[axis] = fit_cubic(x, y, err).as_dict()
        except ValueError as e:
            raise BadInput(f"fit: axis {axis}: {e}") from None
    p = N_COEF[model]
    return {
        "scenario": scenario,
        "model": model,
        "axes": axes,
        "unit": "mm",
        "note": f"rmse = sqrt(sse / (n - {p})); std are 1-sigma from the residuals",
    }


# a stage's error map from a million positions is already far past what a grid needs; a larger
# file held about 11 times its size in memory while being read
MAX_ROWS = 1_000_000


def run_fit(scenario: str, model: str, csv_path: Path, out_dir: Path) -> dict:
    """The ``fit`` command on a stage recording (docs/formats.md's stage format): fit the scenario's
    error model (``quadratic`` or ``cubic`` in x and y, per axis) and write ``fit.json``; returns
    its content (per axis: coefficients in mm, SSE mm^2, R^2, RMSE mm, n)."""
    result = fit_recording(scenario, model, load_stage_csv(csv_path, MAX_ROWS))
    out_dir.mkdir(parents=True, exist_ok=True)
    write_text(out_dir / "fit.json", json.dumps(result, indent=2) + "\n")
    return result
