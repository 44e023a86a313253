"""What a study writes from its finished trials: trials.parquet, summary.json, study.png and
study.rrd."""

from __future__ import annotations

import json
from pathlib import Path

from calibench.scenarios.study.figure import write_study_figure
from calibench.scenarios.study.journal import row_keys
from calibench.scenarios.study.summary import checks_table, summary_table
from calibench.writing import replaced


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
        k for k in row_keys(rows) if k not in keys and k != "traceback" and not k.endswith(".unit")
    )
    table = {k: [r.get(k) for r in rows] for k in keys + cols}
    with replaced(out_dir / "trials.parquet") as tmp:
        pq.write_table(pa.table(table), tmp)
    with replaced(out_dir / "summary.json") as tmp:
        tmp.write_text(json.dumps(summary, indent=2) + "\n")
    if summary["parameters"]:
        with replaced(out_dir / "study.png") as tmp:
            write_study_figure(tmp, rows, summary)
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


def import_writers() -> None:
    """Load what :func:`write_outputs` needs while the workers run: on 2 cores a fast study's
    outputs would otherwise wait a second or two for these imports after its last trial."""
    import cv2  # noqa: F401
    import pyarrow.parquet  # noqa: F401
    import scipy.special  # noqa: F401

    from calibench.scenarios import rrlog  # noqa: F401
