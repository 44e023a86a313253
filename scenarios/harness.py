"""The end of every scenario's run: its figure and its rerun recording, written one way.

A scenario's ``run`` computes a :class:`~calibench.scenarios.report.Report` and the artifacts its
figure and its viewer need (the simulation, images, fits), then hands both to
:func:`write_outputs`. A Monte-Carlo trial has no folder and keeps only the numbers.
"""

from __future__ import annotations

import importlib
from pathlib import Path

from calibench.scenarios.report import Report
from calibench.writing import replaced_in

RRD = "run.rrd"
FIGURE = "figure.png"  # every scenario's run figure has this one name, beside report.json


def write_outputs(
    report: Report, artifacts: dict, out_dir: Path | None, rrd: bool, package: str
) -> Report:
    """Write ``package``'s figure (``package.figure.write_figure(out_dir, report, artifacts)``)
    into ``out_dir``, and with ``rrd`` its rerun recording (``package.viewer.log_run``) as
    ``out_dir/run.rrd`` (without, :func:`without_former_recording` once the report is written);
    nothing when ``out_dir`` is None (a Monte-Carlo trial).

    Parameters
    ----------
    report : the run's report; its ``rrd`` is set when the recording is written.
    artifacts : what the figure and the viewer draw, by name.
    out_dir : the run's folder, or None.
    rrd : whether to write the rerun recording.
    package : the scenario's package, e.g. ``"calibench.scenarios.belt_stage"``.

    Returns
    -------
    The report.
    """
    if out_dir is None:
        return report
    out_dir.mkdir(parents=True, exist_ok=True)  # from Python, a folder not yet made
    with replaced_in(out_dir) as tmp:  # the figure whole or not at all, never through a link
        importlib.import_module(f"{package}.figure").write_figure(tmp, report, artifacts)
    if rrd:
        importlib.import_module(f"{package}.viewer").log_run(out_dir / RRD, report, artifacts)
        report.rrd = RRD
    return report


def without_former_recording(out_dir: Path) -> None:
    """Remove a former run's run.rrd from ``out_dir``, once a report without one is written there:
    left beside it, it would pass for this run's; removed before, a run that then fails would
    have lost it with the former results it keeps."""
    (out_dir / RRD).unlink(missing_ok=True)
