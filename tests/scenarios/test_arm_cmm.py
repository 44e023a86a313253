"""arm-cmm end to end through the CLI: the report, the checks, the rrd."""

import json

from calibench.scenarios.cli import main
from calibench.scenarios.rrlog import entity_paths


def test_run_meets_the_acceptance(tmp_path):
    assert main(["run", "arm-cmm", "--seed", "0", "--out", str(tmp_path)]) == 0
    rep = json.loads((tmp_path / "report.json").read_text())
    assert rep["ok"]
    names = {p["name"] for p in rep["parameters"]}
    assert {"da2", "dtheta2", "tool_z", "tracker_x"} <= names and "dtheta1" not in names
    for p in rep["parameters"]:
        assert p["std"] is not None and abs(p["estimate"] - p["truth"]) <= p["tolerance"], p
    c = {ch["name"]: ch for ch in rep["checks"]}
    assert c["probe_rms_before_mm"]["value"] > 0.5
    assert c["probe_rms_after_mm"]["value"] <= 0.02
    assert c["observability_chosen"]["value"] > c["observability_random"]["value"]
    assert "dtheta1" in c["dropped_parameters"]["note"]
    assert c["identification_s"]["value"] < 1.0
    paths = entity_paths(tmp_path / "run.rrd")
    expected = {"/world/base/joint1/link1/joint2", "/probe/measured", "/probe/modelled_after",
                "/residual_mm/before", "/residual_mm/after"}
    assert expected <= paths, expected - paths
