"""probe-scanner end to end, and the full-data method against the paper's over 50 seeds."""

import json

import numpy as np

from calibench.estimators.probe_scanner.calibration import calibrate_lsq, calibrate_paper
from calibench.scenarios.cli import main
from calibench.scenarios.probe_scanner import scenario as probe_scanner
from calibench.scenarios.rrlog import entity_paths
from calibench.scenes.probe_scanner import ProbeScannerGeometry
from calibench.sim.probe_scanner import ProbeScannerSim, ProbeScannerTruth


def test_run_meets_the_acceptance(tmp_path):
    assert main(["run", "probe-scanner", "--seed", "0", "--out", str(tmp_path)]) == 0
    rep = json.loads((tmp_path / "report.json").read_text())
    names = {p["name"] for p in rep["parameters"]}
    assert {"d_paper", "dL_paper", "alpha0_paper", "d_lsq", "dL_lsq", "alpha0_lsq"} <= names
    checks = {c["name"]: c for c in rep["checks"]}
    assert checks["contour_rms_after_mm"]["value"] <= 3 * 0.005  # a few encoder quanta
    assert checks["contour_rms_before_mm"]["value"] > 10 * checks["contour_rms_after_mm"]["value"]
    assert checks["paper_m"]["value"] == 50
    # the report says where m meets the 0.5 mm requirement; the paper finds about 40-60
    ranges = rep["info"]["m_meeting_requirement_rms_over_turns"]
    longest = max(ranges, key=lambda r: r[1] - r[0])
    assert longest[0] <= 50 <= longest[1] and longest[0] >= 20 and longest[1] <= 95
    assert (tmp_path / "figure.png").is_file()
    paths = entity_paths(tmp_path / "run.rrd")
    expected = {
        "/world/turntable",
        "/world/turntable/rail/rail",
        "/world/holder/plate",
        "/rho/plate_mm",
        "/rho_plot/minima",
        "/rho_plot/quadratic_fits",
        "/contours/rim_true",
        "/contours/rim_traced_after",
        "/figures/probe_scanner",
    }
    assert expected <= paths, expected - paths


def test_full_data_method_is_ten_times_more_accurate_on_d_over_50_seeds():
    g, truth = ProbeScannerGeometry(), ProbeScannerTruth()
    sim = ProbeScannerSim(g, truth)
    nominal = probe_scanner.ProbeScannerConfig().nominal
    a, r = g.plate.half_side_mm, g.plate.corner_radius_mm
    err_paper, err_lsq = [], []
    for seed in range(50):
        scan, _ = sim.scan("plate", np.random.default_rng(1000 + seed))
        paper = calibrate_paper(scan.theta_rad, scan.rho_mm, 50, a, nominal.alpha0_rad)
        lsq = calibrate_lsq(scan.theta_rad, scan.rho_mm, a, r, paper)
        err_paper.append(paper.d_mm - truth.d_mm)
        err_lsq.append(lsq.d_mm - truth.d_mm)
    rms_paper = np.sqrt(np.mean(np.square(err_paper)))
    rms_lsq = np.sqrt(np.mean(np.square(err_lsq)))
    assert rms_paper / rms_lsq >= 10, (rms_paper, rms_lsq)
