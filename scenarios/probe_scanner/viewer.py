"""What a ``probe-scanner`` run shows in rerun (all calls go through ``scenarios.rrlog``).

Timeline ``sample``: the turntable turning through the plate's turn, rho(theta) with the four
minima and their quadratic fits, and the rim's contours, traced and true, in the holder plane.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from calibench.scenarios import rrlog
from calibench.scenarios.harness import FIGURE


def log_run(path: Path, report, a: dict) -> None:
    """Write the run's rerun recording to ``path`` with its layout."""
    path.parent.mkdir(parents=True, exist_ok=True)
    rec = rrlog.open_recording(path, "calibench-probe-scanner")
    try:
        sim = a["sim"]
        paths = rrlog.log_mujoco_bodies(rec, sim.model)
        V = rrlog.View
        rrlog.send_layout(
            rec,
            [
                [
                    V("3d", "world", "the scanner", eye=rrlog.eye_on(sim.model, (0.6, -0.9, 0.8))),
                    V("3d", "contours", "contours: true and traced (before, after, paper's)"),
                ],
                [
                    V("plot", "rho", "probe reading rho (mm) by sample"),
                    V("2d", "rho_plot", "rho over the turn, minima fits"),
                ],
                [V("text", "report", "truth against estimate"), V("2d", "figures", "figures")],
            ],
            "sample",
        )
        plate = a["plate"]
        z = 0.004
        for i in range(0, len(plate.theta_rad), 8):
            rrlog.set_step(rec, "sample", i)
            sim.turn_to(plate.theta_rad[i])
            rrlog.log_body_poses(rec, paths, sim.data.xpos, sim.data.xquat, sim.model.body_parentid)
            rrlog.log_scalar(rec, "rho/plate_mm", plate.rho_mm[i])
            p = a["contours_plate"][i] / 1000
            rrlog.log_points3d(rec, "world/contact", np.r_[p, z], rrlog.ORANGE, radius=0.0008)
        for k, f in enumerate(a["minima"]):
            rrlog.set_step(
                rec, "sample", int(round(f.theta_rad / (2 * np.pi) * len(plate.theta_rad)))
            )
            rrlog.log_scalar(rec, f"rho/minimum_{k}_mm", f.rho_mm)
        x = np.linspace(-0.3, 0.3, 61)
        fits = [
            np.c_[np.rad2deg(f.theta_rad + x), f.rho_mm + 0.5 * f.curvature_mm * x * x]
            for f in a["minima"]
        ]
        rrlog.log_line_strips2d(rec, "rho_plot/quadratic_fits", fits, rrlog.ORANGE)
        rrlog.log_line_strips2d(
            rec, "rho_plot/rho", [np.c_[np.rad2deg(plate.theta_rad), plate.rho_mm]], rrlog.BLUE
        )
        rrlog.log_points2d(
            rec,
            "rho_plot/minima",
            np.array([[np.rad2deg(f.theta_rad), f.rho_mm] for f in a["minima"]]),
            rrlog.RED,
            2.0,
        )
        lift = np.full((len(a["outline"]), 1), z)
        rrlog.log_line_strips3d(
            rec, "contours/rim_true", [np.c_[a["outline"][::20] / 1000, lift[::20]]], (20, 20, 20)
        )
        rrlog.log_line_strips3d(
            rec,
            "contours/plate_true",
            [
                np.c_[
                    a["plate_outline"][::50] / 1000, np.full((len(a["plate_outline"][::50]), 1), z)
                ]
            ],
            (20, 20, 20),
        )
        for name, colour in (
            ("before", rrlog.RED),
            ("paper", rrlog.ORANGE),
            ("after", rrlog.GREEN),
        ):
            c = a["contours"][name] / 1000
            rrlog.log_points3d(
                rec,
                f"contours/rim_traced_{name}",
                np.c_[c, np.full(len(c), z)],
                colour,
                radius=0.0002,
                static=True,
            )
        rrlog.log_text(rec, "report", f"# probe-scanner, seed {report.seed}\n\n" + report.table())
        png = path.parent / FIGURE
        if png.exists():
            rrlog.log_figure(rec, "figures/probe_scanner", png)
    finally:
        rrlog.close(rec)
