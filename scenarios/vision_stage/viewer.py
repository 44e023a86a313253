"""What a ``vision-stage`` run shows in rerun (all calls go through ``scenarios.rrlog``).

Timelines: ``circle`` for the microscope images kept from the point-pair acquisition. The error
field is drawn in the table's plane, magnified (``ARROW_GAIN``), before and after compensation.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from calibench.scenarios import rrlog
from calibench.scenarios.harness import FIGURE
from calibench.scenes.camera import MJ_TO_CV

ARROW_GAIN = 1000.0  # um-sized errors drawn 1000 x (1 um -> 1 mm)


def log_run(path: Path, report, a: dict) -> None:
    """Write the run's rerun recording to ``path`` with its layout."""
    path.parent.mkdir(parents=True, exist_ok=True)
    rec = rrlog.open_recording(path, "calibench-vision-stage")
    try:
        sim, g = a["sim"], a["geometry"]
        paths = rrlog.log_mujoco_bodies(rec, sim.model, skip=lambda name: name.startswith("tile"))
        V = rrlog.View
        rrlog.send_layout(
            rec,
            [
                [
                    V("3d", "world", "the table under the microscope", eye=rrlog.eye_on(sim.model)),
                    V("3d", "error_field", "error field: true, measured, after the cubic"),
                ],
                [
                    V("2d", "world/microscope", "microscope: detected green, true red"),
                    V("plot", "interferometer", "interferometer deviations (um) by target"),
                ],
                [V("text", "report", "truth against estimate"), V("2d", "figures", "figures")],
            ],
            "target_mm",
        )
        # the plate as one textured quad (441 tile meshes would weigh tens of MB)
        tile = g.plate.tile_texture(32)
        n, pitch = g.plate.n, g.plate.pitch_mm / 1000
        image = np.tile(tile, (n, n, 1))
        lo, hi = -pitch / 2, (n - 0.5) * pitch
        # image row 0 is drawn at the quad's +y edge: the rows run from the last circle row down
        rrlog.log_textured_quad(
            rec,
            paths[sim.model.body("plate").id] + "/circles",
            np.array([[lo, lo, 0], [hi, lo, 0], [hi, hi, 0], [lo, hi, 0]]),
            image,
        )
        sim.move(*a["s00"])
        rrlog.log_body_poses(rec, paths, sim.data.xpos, sim.data.xquat, sim.model.body_parentid)
        R, p = _cam2world(sim)
        cam = g.camera
        rrlog.log_camera(rec, "world/microscope", cam.K, (cam.width, cam.height), R, p)
        for step, (_, img, found, true) in enumerate(a["images"]):
            rrlog.set_step(rec, "circle", step)
            rrlog.log_image(rec, "world/microscope/image", img)
            rrlog.log_points2d(rec, "world/microscope/image/true", true, rrlog.RED, 4.0)
            rrlog.log_points2d(rec, "world/microscope/image/detected", found, rrlog.GREEN, 2.5)

        # the error field on the readings' grid, in metres, drawn beside the machine
        r, e = a["readings"], a["err_um"]
        origins = np.c_[(r - r[0]) / 1000 + [0.0, 0.35], np.full(len(r), 0.0)]
        after = e - a["models"]["polynomial"](r)
        true = a["true_err"]
        for name, field, colour in (
            ("measured_before", e, rrlog.RED),
            ("true_before", true, rrlog.ORANGE),
            ("after_cubic", after, rrlog.GREEN),
        ):
            vec = np.c_[field / 1000 * ARROW_GAIN / 1000, np.zeros(len(field))]
            rrlog.log_arrows3d(rec, f"error_field/{name}", origins, vec, colour, radius=0.0008)
        for name, lines in a["verification"].items():
            for ln in lines:
                mean = (ln["iso"].mean_up + ln["iso"].mean_down) / 2
                for t, m in zip(ln["targets_mm"], mean):
                    rrlog.set_step(rec, "target_mm", int(round(t)))
                    rrlog.log_scalar(
                        rec, f"interferometer/{name}/{ln['axis']}_at_{ln['at_mm']:g}_um", m
                    )
        rrlog.log_text(
            rec,
            "report",
            f"# vision-stage, seed {report.seed}, {report.fidelity}\n\n"
            f"Error arrows x{ARROW_GAIN:g}.\n\n" + report.table(),
        )
        png = path.parent / FIGURE
        if png.exists():
            rrlog.log_figure(rec, "figures/vision_stage", png)
    finally:
        rrlog.close(rec)


def _cam2world(sim):
    c = sim.model.camera("microscope").id
    return sim.data.cam_xmat[c].reshape(3, 3) @ MJ_TO_CV, sim.data.cam_xpos[c].copy()
