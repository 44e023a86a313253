"""What an ``arm-cmm`` run shows in rerun (all calls go through ``scenarios.rrlog``).

Timeline ``posture``: the arm through the chosen postures, the measured reflector point (the
tracker's reading taken into the base frame by the identified frame) and the modelled ones, and
the residual per posture before and after identification.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from calibench.scenarios import rrlog
from calibench.scenarios.arm_cmm.figure import posture_residuals
from calibench.scenarios.harness import FIGURE


def log_run(path: Path, report, a: dict) -> None:
    """Write the run's rerun recording to ``path`` with its layout."""
    path.parent.mkdir(parents=True, exist_ok=True)
    rec = rrlog.open_recording(path, "calibench-arm-cmm")
    try:
        sim = a["sim"]
        paths = rrlog.log_mujoco_bodies(rec, sim.model)
        V = rrlog.View
        rrlog.send_layout(
            rec,
            [
                [
                    V("3d", "world", "the arm and its tracker", eye=rrlog.eye_on(sim.model)),
                    V("3d", "probe", "probe points: measured, modelled before and after"),
                ],
                [V("plot", "residual_mm", "residual (mm) by posture: before, after")],
                [V("text", "report", "truth against estimate"), V("2d", "figures", "figures")],
            ],
            "posture",
        )
        problem, st = a["problem"], a["ident"].state
        r, az, el = problem.meas.T
        y = np.stack(
            [r * np.cos(el) * np.cos(az), r * np.cos(el) * np.sin(az), r * np.sin(el)], axis=1
        )
        measured_base = (y - st.t) @ st.R  # tracker frame -> base frame, identified
        modelled_before = (problem.points(a["start"]) - st.t) @ st.R
        modelled_after = (problem.points(st) - st.t) @ st.R
        before, after = posture_residuals(a)
        for i, q in enumerate(a["postures"]):
            rrlog.set_step(rec, "posture", i)
            sim.set_posture(q)
            rrlog.log_body_poses(rec, paths, sim.data.xpos, sim.data.xquat, sim.model.body_parentid)
            rrlog.log_points3d(
                rec, "probe/measured", measured_base[i] / 1000, rrlog.BLUE, radius=0.006
            )
            rrlog.log_points3d(
                rec, "probe/modelled_before", modelled_before[i] / 1000, rrlog.RED, radius=0.004
            )
            rrlog.log_points3d(
                rec, "probe/modelled_after", modelled_after[i] / 1000, rrlog.GREEN, radius=0.004
            )
            rrlog.log_scalar(rec, "residual_mm/before", before[i])
            rrlog.log_scalar(rec, "residual_mm/after", after[i])
        rrlog.log_points3d(
            rec, "probe/all_measured", measured_base / 1000, rrlog.BLUE, radius=0.003, static=True
        )
        rrlog.log_text(rec, "report", f"# arm-cmm, seed {report.seed}\n\n" + report.table())
        png = path.parent / FIGURE
        if png.exists():
            rrlog.log_figure(rec, "figures/arm_cmm", png)
    finally:
        rrlog.close(rec)
