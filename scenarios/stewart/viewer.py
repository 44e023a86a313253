"""What a ``stewart`` run shows in rerun (all calls go through ``scenarios.rrlog``).

Timeline ``pose``: the platform and legs through the one-step poses, the tracker's beams from
its three stations to the reflectors; static: the stations and the two-step method's spheres.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from calibench.scenarios import rrlog
from calibench.scenarios.harness import FIGURE


def log_run(path: Path, report, a: dict) -> None:
    """Write the run's rerun recording to ``path`` with its layout."""
    path.parent.mkdir(parents=True, exist_ok=True)
    rec = rrlog.open_recording(path, "calibench-stewart")
    try:
        sim = a["sim"]
        paths = rrlog.log_mujoco_bodies(rec, sim.model)
        V = rrlog.View
        rrlog.send_layout(
            rec,
            [
                [
                    V(
                        "3d",
                        "/",
                        "the platform and the tracker's beams",
                        contents=("+ world/**", "+ tracker/**"),
                        eye=rrlog.eye_on(sim.model),
                    )
                ],
                [
                    V("3d", "two_step", "two-step hinge spheres"),
                    V("text", "report", "truth against estimate"),
                    V("2d", "figures", "figures"),
                ],
            ],
            "pose",
        )
        rrlog.log_points3d(
            rec, "tracker/stations", a["stations"] / 1000, rrlog.BLUE, radius=0.02, static=True
        )
        for i, (R, t) in enumerate(a["poses"]):
            rrlog.set_step(rec, "pose", i)
            sim.set_pose(R, t)
            rrlog.log_body_poses(rec, paths, sim.data.xpos, sim.data.xquat, sim.model.body_parentid)
            refl = sim.reflectors_mm() / 1000
            beams = [np.stack([s / 1000, p]) for s in a["stations"] for p in refl]
            rrlog.log_line_strips3d(rec, "tracker/beams", beams, rrlog.ORANGE, static=False)
        u = np.linspace(0, 2 * np.pi, 48)
        for leg, spheres in enumerate(a["spheres"]):
            for k, (c, r, pts) in enumerate(spheres):
                rings = [
                    np.c_[
                        c[0] + r * np.cos(u) * np.cos(e),
                        c[1] + r * np.sin(u) * np.cos(e),
                        np.full(48, c[2] + r * np.sin(e)),
                    ]
                    / 1000
                    for e in np.deg2rad([70, 80, 88])
                ]
                rrlog.log_line_strips3d(rec, f"two_step/leg{leg + 1}/sphere{k}", rings, rrlog.GREEN)
                rrlog.log_points3d(
                    rec,
                    f"two_step/leg{leg + 1}/origins{k}",
                    pts / 1000,
                    rrlog.RED,
                    radius=0.004,
                    static=True,
                )
        rrlog.log_text(rec, "report", f"# stewart, seed {report.seed}\n\n" + report.table())
        png = path.parent / FIGURE
        if png.exists():
            rrlog.log_figure(rec, "figures/stewart", png)
    finally:
        rrlog.close(rec)
