"""Each scenario's .rrd opens on its layout: read the file back and check the views, the plots'
timelines and the entity count (the web viewer could not load 2,240 separate meshes)."""

import numpy as np
import pytest

from calibench.scenarios.cli import main
from calibench.scenarios.rrlog import entity_paths, layout_views, timelines

# scenario: (timeline of its plots, {(view kind, origin)} the layout must hold)
LAYOUTS = {
    "belt-stage": (
        "station",
        {
            ("3D", "world"),
            ("3D", "error_map"),
            ("2D", "world/overhead"),
            ("2D", "calibration"),
            ("TimeSeries", "error_map/station_error_mm"),
            ("TextDocument", "report"),
            ("2D", "figures"),
        },
    ),
    "vision-stage": (
        "target_mm",
        {
            ("3D", "world"),
            ("3D", "error_field"),
            ("2D", "world/microscope"),
            ("TimeSeries", "interferometer"),
            ("TextDocument", "report"),
            ("2D", "figures"),
        },
    ),
    "probe-scanner": (
        "sample",
        {
            ("3D", "world"),
            ("3D", "contours"),
            ("TimeSeries", "rho"),
            ("2D", "rho_plot"),
            ("TextDocument", "report"),
            ("2D", "figures"),
        },
    ),
    "arm-cmm": (
        "posture",
        {
            ("3D", "world"),
            ("3D", "probe"),
            ("TimeSeries", "residual_mm"),
            ("TextDocument", "report"),
            ("2D", "figures"),
        },
    ),
    "stewart": (
        "pose",
        {("3D", "/"), ("3D", "two_step"), ("TextDocument", "report"), ("2D", "figures")},
    ),
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
        under = {
            p: t
            for p, t in logged.items()
            if not root or p.strip("/") == root or p.strip("/").startswith(root + "/")
        }
        assert under, f"{scenario}: nothing logged under {origin}"
        if kind == "TimeSeries":  # on the layout's timeline, and on no other step timeline
            for p, t in under.items():
                assert t - {"log_time"} == {timeline}, (p, t)
    # 2-D figures stay out of the 3-D roots (a 2-D visualizer there needs a pinhole ancestor)
    assert not any(p.strip("/").startswith("world/figures") for p in paths)


def test_the_arm_is_logged_as_one_connected_chain_at_every_posture(tmp_path):
    """Every body of the arm is logged at every posture relative to its parent: its origin must
    stay where the joint holds it (the same translation at every posture: links never come
    apart) and a joint's body may only turn about one fixed axis."""
    from calibench.scenarios.rrlog import transforms

    assert main(["run", "arm-cmm", "--arm", "ur10", "--out", str(tmp_path)]) == 0
    logged = transforms(tmp_path / "run.rrd", "posture")
    chain = {p: d for p, d in logged.items() if p.startswith("/world/base")}
    assert len(chain) >= 13  # base, 6 joints, 6 links (and the tool)
    n_postures = max(len(d) for d in chain.values())
    for path, d in chain.items():
        assert len(d) == n_postures, path
        T = np.array([t for t, _ in d.values()])
        assert np.ptp(T, axis=0).max() < 1e-9, path
        R = [r for _, r in d.values()]
        axes = []
        for Rk in R[1:]:
            D = Rk @ R[0].T
            w = np.array([D[2, 1] - D[1, 2], D[0, 2] - D[2, 0], D[1, 0] - D[0, 1]])
            if np.linalg.norm(w) > 1e-6:
                axes.append(w / np.linalg.norm(w))
        if axes:
            assert path.rsplit("/", 1)[-1].startswith("joint"), path  # only joints turn
            assert np.max(1 - np.abs(np.array(axes) @ axes[0])) < 1e-9, path
