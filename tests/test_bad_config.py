"""Config values that pass the type and sign checks but make no workable set-up.

Each case is a ``--config`` table a probe fed ``calibench run`` (and which ended in an internal
error, a hang, or a nonsense estimate): it must now be bad input, said when the config is read,
before any simulation: exit status 2, one line on stderr naming the key, no traceback, no result.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from calibench.scenarios.cli import main

RESULTS = ("report.json", "summary.json")

# (id, scenario, TOML, the key the line must name)
CASES = [
    # belt-stage
    (
        "belt-camera-below-board",
        "belt-stage",
        "[belt-stage.geometry]\ncamera_height_mm = 1.0\n",
        "camera_height_mm",
    ),
    (
        "belt-principal-point-off-image",
        "belt-stage",
        "[belt-stage.geometry.camera]\ncx = -5000.0\n",
        "cx = -5000",
    ),
    ("belt-lens-k1-huge", "belt-stage", "[belt-stage.geometry.camera]\nk1 = 1e6\n", "k1 = 1e+06"),
    ("belt-lens-folds", "belt-stage", "[belt-stage.geometry.camera]\nk1 = -0.9\n", "k1 = -0.9"),
    (
        "belt-negative-mass",
        "belt-stage",
        "[belt-stage.truth.belt_x]\ncarriage_kg = -1.0\nea_n = 1e5\n",
        "carriage_kg",
    ),
    (
        "belt-zero-mass",
        "belt-stage",
        "[belt-stage.truth.belt_y]\ncarriage_kg = 0.0\n",
        "carriage_kg",
    ),
    (
        "belt-board-huge",
        "belt-stage",
        "[belt-stage.geometry.board]\nsquare_mm = 1e6\n",
        "square_mm",
    ),
    (
        "belt-board-margin-not-whole-pixels",
        "belt-stage",
        "[belt-stage.geometry.board]\nsquare_mm = 30.0\n",
        "square_mm",
    ),
    (
        "belt-stations-beyond-travel",
        "belt-stage",
        "[belt-stage]\nstations_x_mm = [0, 5000, 9000]\n",
        "stations_x_mm",
    ),
    (
        "belt-stations-negative",
        "belt-stage",
        "[belt-stage]\nstations_y_mm = [-100, 0, 100, 200]\n",
        "stations_y_mm",
    ),
    ("belt-one-station", "belt-stage", "[belt-stage]\nstations_x_mm = [0]\n", "stations_x_mm"),
    (
        "belt-two-stations",
        "belt-stage",
        "[belt-stage]\nstations_y_mm = [0, 500]\n",
        "stations_y_mm",
    ),
    ("belt-no-stations", "belt-stage", "[belt-stage]\nstations_x_mm = []\n", "stations_x_mm"),
    (
        "belt-stations-repeated",
        "belt-stage",
        "[belt-stage]\nstations_x_mm = [0, 100, 100, 200]\n",
        "stations_x_mm",
    ),
    (
        "belt-travel-huge",
        "belt-stage",
        "[belt-stage.geometry]\ntravel_mm = [1e9, 1e9]\n",
        "travel_mm",
    ),
    (
        "belt-error-map-huge",
        "belt-stage",
        "[belt-stage.truth]\nerror_x = [0, 0.5, 0, 0, 0, 0]\n",
        "error_x",
    ),
    (
        "belt-error-map-out-of-view",
        "belt-stage",
        "[belt-stage.truth]\nerror_y = [0, 0, 0.09, 0, 0, 0]\n",
        "error_y",
    ),
    # vision-stage
    ("vision-grid-too-small", "vision-stage", "[vision-stage]\ngrid = [2, 2]\n", "grid"),
    ("vision-grid-too-large", "vision-stage", "[vision-stage]\ngrid = [1000, 1000]\n", "grid"),
    ("vision-grid-beyond-travel", "vision-stage", "[vision-stage]\ngrid = [20, 14]\n", "grid"),
    (
        "vision-line-off-table",
        "vision-stage",
        "[vision-stage]\nx_lines_at_y_mm = [1e6]\n",
        "x_lines_at_y_mm",
    ),
    (
        "vision-no-lines",
        "vision-stage",
        "[vision-stage]\ny_lines_at_x_mm = []\n",
        "y_lines_at_x_mm",
    ),
    (
        "vision-ruler-pitch-huge",
        "vision-stage",
        "[vision-stage]\nruler_pitch_mm = 1e6\n",
        "ruler_pitch_mm",
    ),
    (
        "vision-ruler-pitch-tiny",
        "vision-stage",
        "[vision-stage]\nruler_pitch_mm = 1e-6\n",
        "ruler_pitch_mm",
    ),
    (
        "vision-ruler-aim-huge",
        "vision-stage",
        "[vision-stage]\nruler_aim_um = 1e6\n",
        "ruler_aim_um",
    ),
    (
        "vision-squareness-3-rad",
        "vision-stage",
        "[vision-stage.truth]\nsquareness_rad = 3.0\n",
        "squareness_rad",
    ),
    ("vision-turn-error-huge", "vision-stage", "[vision-stage]\nturn_error = 1e9\n", "turn_error"),
    (
        "vision-working-distance-tiny",
        "vision-stage",
        "[vision-stage.geometry]\nworking_distance_mm = 1e-9\n",
        "working_distance_mm",
    ),
    # probe-scanner
    ("scanner-d-huge", "probe-scanner", "[probe-scanner.truth]\nd_mm = 1e6\n", "d_mm"),
    ("scanner-d-negative", "probe-scanner", "[probe-scanner.truth]\nd_mm = -8.0\n", "d_mm"),
    (
        "scanner-corner-radius-huge",
        "probe-scanner",
        "[probe-scanner.geometry.plate]\ncorner_radius_mm = 100.0\n",
        "corner_radius_mm",
    ),
    (
        "scanner-window-over-quarter-turn",
        "probe-scanner",
        "[probe-scanner]\npaper_m = 1000\n",
        "paper_m",
    ),
    (
        "scanner-runout-fractional-harmonic",
        "probe-scanner",
        "[probe-scanner.truth]\nrunout_harmonics = [1.5]\nrunout_mm = [0.003]\nrunout_phase_rad = "
        "[0.0]\n",
        "runout_harmonics",
    ),
    (
        "scanner-runout-harmonic-zero",
        "probe-scanner",
        "[probe-scanner.truth]\nrunout_harmonics = [0]\nrunout_mm = [0.003]\nrunout_phase_rad = "
        "[0.0]\n",
        "runout_harmonics",
    ),
    # stewart
    (
        "stewart-pitch-error-without-lead",
        "stewart",
        "[stewart.truth]\nleg_pitch_um = [2.0, 0, 0, 0, 0, 0]\n",
        "leg_pitch_lead_mm",
    ),
    (
        "stewart-negative-compliance",
        "stewart",
        "[stewart.truth]\nleg_compliance_um_per_n = [-1e6, 0, 0, 0, 0, 0]\npayload_n = 1000.0\n",
        "leg_compliance_um_per_n",
    ),
    (
        "stewart-compliance-huge",
        "stewart",
        "[stewart.truth]\nleg_compliance_um_per_n = [1e4, 1e4, 1e4, 1e4, 1e4, 1e4]\npayload_n = "
        "1000.0\n",
        "leg_compliance_um_per_n",
    ),
    (
        "stewart-hinge-error-huge",
        "stewart",
        "[stewart.truth]\nhinge_error_mm = 1e5\n",
        "hinge_error_mm",
    ),
    ("stewart-too-few-poses", "stewart", "[stewart]\nn_poses = 3\n", "n_poses"),
    (
        "stewart-platform-hinges-zero",
        "stewart",
        "[stewart.geometry]\nplatform_hinges_mm = "
        "[[0,0,0],[0,0,0],[0,0,0],[0,0,0],[0,0,0],[0,0,0]]\n",
        "platform_hinges_mm",
    ),
    ("stewart-rotation-720", "stewart", "[stewart]\nrotation_deg = 720.0\n", "rotation_deg"),
    ("stewart-home-far", "stewart", "[stewart.geometry]\nhome_height_mm = 1e6\n", "home_height_mm"),
    (
        "stewart-translation-beyond-stroke",
        "stewart",
        "[stewart]\ntranslation_mm = 1e5\n",
        "translation_mm",
    ),
]


def _check(capsys, d: Path, argv: list[str], key: str) -> None:
    """Exit 2, one line naming ``key``, no traceback, no result file (test_bad_input's contract)."""
    before = set(d.rglob("*"))
    got = main(argv)
    err = capsys.readouterr().err.strip()
    assert "Traceback" not in err, err
    assert got == 2, f"exit {got}: {err}"
    lines = err.splitlines()
    assert len(lines) == 1, err
    assert lines[0].startswith("calibench: config: "), err
    assert key in lines[0], err
    new = set(d.rglob("*")) - before
    assert not [p for p in new if p.name in RESULTS], new


@pytest.mark.parametrize("case", CASES, ids=[c[0] for c in CASES])
def test_bad_config_is_one_line_naming_the_key(case, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    _, scenario, toml, key = case
    (tmp_path / "c.toml").write_text(toml)
    _check(
        capsys,
        tmp_path,
        [
            "run",
            scenario,
            "--config",
            str(tmp_path / "c.toml"),
            "--fidelity",
            "analytic",
            "--out",
            str(tmp_path / "o"),
        ],
        key,
    )


def test_a_study_refuses_a_bad_config_too(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "c.toml").write_text("[stewart]\nn_poses = 3\n")
    _check(
        capsys,
        tmp_path,
        [
            "montecarlo",
            "stewart",
            "--config",
            str(tmp_path / "c.toml"),
            "--trials",
            "1",
            "--workers",
            "1",
            "--out",
            str(tmp_path / "o"),
        ],
        "n_poses",
    )


def test_every_default_config_and_sampled_truth_passes_the_checks():
    """The defaults of every scenario, and the truths a Monte-Carlo study samples (prior, 50
    trials), lie within the ranges the checks allow."""
    from calibench.scenarios.config import override
    from calibench.scenarios.registry import SCENARIOS
    from calibench.scenarios.study.trials import trial_seed

    for name, s in SCENARIOS.items():
        module = sys.modules[s.run.__module__]
        config = override(s.config(), {}, name)
        # the arm's config checks itself when made; what remains is that its cones are in reach
        check = module.check_cones if name == "arm-cmm" else module.check_config
        check(config)
        for k in range(50):
            check(module.prior(config, np.random.default_rng(trial_seed(0, k))))
