"""Each scenario's .rrd opens on its layout: read the file back and check the views, the plots'
timelines and the entity count (the web viewer could not load 2,240 separate meshes)."""

import pytest

from calibench.scenarios.cli import main
from calibench.scenarios.rrlog import entity_paths, layout_views, timelines

# scenario: (timeline of its plots, {(view kind, origin)} the layout must hold)
LAYOUTS = {
    "belt-stage": ("station", {("3D", "world"), ("3D", "error_map"), ("2D", "world/overhead"), ("2D", "calibration"),
                               ("TimeSeries", "error_map/station_error_mm"), ("TextDocument", "report"),
                               ("2D", "figures")}),
    "vision-stage": ("target_mm", {("3D", "world"), ("3D", "error_field"), ("2D", "world/microscope"),
                                   ("TimeSeries", "interferometer"), ("TextDocument", "report"), ("2D", "figures")}),
    "probe-scanner": ("sample", {("3D", "world"), ("3D", "contours"), ("TimeSeries", "rho"), ("2D", "rho_plot"),
                                 ("TextDocument", "report"), ("2D", "figures")}),
    "arm-cmm": ("posture", {("3D", "world"), ("3D", "probe"), ("TimeSeries", "residual_mm"), ("TextDocument", "report"),
                            ("2D", "figures")}),
    "stewart": ("pose", {("3D", "/"), ("3D", "two_step"), ("TextDocument", "report"), ("2D", "figures")}),
}
MAX_ENTITIES = 100


@pytest.mark.parametrize("scenario", list(LAYOUTS))
def test_recording_opens_on_its_layout(scenario, tmp_path):
    out = tmp_path / scenario
    assert main(["run", scenario, "--fidelity", "analytic", "--out", str(out)]) in (0, 1)
    rrd = out / "run.rrd"
    timeline, expected = LAYOUTS[scenario]
    views = layout_views(rrd)
    assert expected <= {(v["kind"], v["origin"]) for v in views}
    assert all(v["name"] for v in views)  # every view says what it shows
    paths = entity_paths(rrd)
    assert len(paths) <= MAX_ENTITIES, len(paths)
    logged = timelines(rrd)
    for kind, origin in expected:
        root = origin.strip("/")
        under = {p: t for p, t in logged.items() if not root or p.strip("/") == root or p.strip("/").startswith(root + "/")}
        assert under, f"{scenario}: nothing logged under {origin}"
        if kind == "TimeSeries":  # on the layout's timeline, and on no other step timeline
            for p, t in under.items():
                assert t - {"log_time"} == {timeline}, (p, t)
    # 2-D figures stay out of the 3-D roots (a 2-D visualizer there needs a pinhole ancestor)
    assert not any(p.strip("/").startswith("world/figures") for p in paths)
