"""``calibench acceptance`` (issue 64): the standards' tests on the arm's twin, before and after
calibration.

The figures' formulas are checked on draws of a known distribution; the procedures end to end on
the seed's arm, whose drawing is millimetres off its twin and whose calibration on 200 tracker
postures leaves a few micrometres.
"""

import json

import numpy as np
import pytest

from calibench.scenarios.arm_cmm.acceptance import pose_figures
from calibench.scenarios.arm_cmm.iso10360 import (
    SPHERE_MM,
    figures,
    fitted_sphere,
    sphere_directions,
)
from calibench.scenarios.cli import main

CHI3_MEAN = np.sqrt(8 / np.pi)  # the mean length of a 3-D standard Gaussian vector
CHI3_STD = np.sqrt(3 - 8 / np.pi)


def test_iso9283_figures_of_a_known_scatter():
    """Attained points offset by a known vector with isotropic scatter s: AP is the offset's
    length (to the mean's error, s / sqrt(n) per axis) and RP is s (chi_3's mean + 3 of its
    standard deviations) = 3.616 s, to 5 of its own errors over 3000 cycles."""
    rng = np.random.default_rng(5)
    s, cycles = 0.02, 3000
    commanded = rng.uniform(-500, 500, (5, 3))
    offset = np.array([0.05, -0.03, 0.1])
    attained = commanded + offset + rng.normal(0, s, (cycles, 5, 3))
    AP, RP = pose_figures(attained, commanded)
    np.testing.assert_allclose(AP, np.linalg.norm(offset), atol=5 * s / np.sqrt(cycles))
    rp = s * (CHI3_MEAN + 3 * CHI3_STD)
    # l's mean and std each to about s chi3_std / sqrt(n) and s / sqrt(2 n)
    np.testing.assert_allclose(RP, rp, atol=5 * s * (CHI3_STD + 3 / np.sqrt(2)) / np.sqrt(cycles))


def test_the_probing_sphere_is_fitted_to_its_noise():
    """25 points of the test's pattern on a 12.5 mm sphere, 1 um of noise: centre and radius
    within 4 of their errors (about sigma / sqrt(25) each); exact points: no form at all."""
    rng = np.random.default_rng(6)
    centre, radius = np.array([400.0, -120.0, 300.0]), 12.5
    exact = centre + radius * sphere_directions()
    c, r = fitted_sphere(exact)
    assert np.ptp(np.linalg.norm(exact - c, axis=1)) < 1e-9 and r == pytest.approx(radius, abs=1e-9)
    c, r = fitted_sphere(exact + rng.normal(0, 1e-3, exact.shape))
    assert abs(r - radius) < 4 * 1e-3 / np.sqrt(25) * 2 and np.linalg.norm(c - centre) < 4e-3


def test_iso10360_12_figures_of_known_measurements():
    """Measurements made by hand with known errors: bars read 3 um long and 5 um short (E_UNI 5),
    six locations on the axes at +-4 um about a centre (L_Dia 8: the diameter that holds them),
    the sphere probed exactly at a radius 2 um large (P_Size 4, P_Form 0), then one point pushed
    out by 3 um (P_Form about 3, the fit sharing it over 25 points)."""
    rng = np.random.default_rng(9)
    bars = np.array([150.0, 300.0])
    u = rng.normal(size=(2, 3))
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    measured = bars + np.array([0.003, -0.005])
    ends = np.stack([np.zeros((2, 3)) + 100.0, 100.0 + u * measured[:, None]], 1)
    centres = np.array([400.0, 50.0, 200.0]) + 0.004 * np.vstack([np.eye(3), -np.eye(3)])
    sphere = np.array([10.0, -20.0, 300.0]) + (SPHERE_MM / 2 + 0.002) * sphere_directions()
    f = figures(bars, ends, centres, sphere)
    assert f["E_UNI_um"] == pytest.approx(5.0, abs=1e-6)
    assert f["length_errors_um"] == pytest.approx([3.0, -5.0], abs=0.01)
    assert f["L_Dia_um"] == pytest.approx(8.0, abs=1e-6)
    assert f["P_Size_um"] == pytest.approx(4.0, abs=1e-6) and f["P_Form_um"] < 1e-6
    bumped = sphere.copy()
    bumped[0] += (
        0.003 * (bumped[0] - sphere.mean(axis=0)) / np.linalg.norm(bumped[0] - sphere.mean(axis=0))
    )
    assert figures(bars, ends, centres, bumped)["P_Form_um"] == pytest.approx(3.0, rel=0.15)


@pytest.fixture(scope="module")
def iso10360(tmp_path_factory):
    out = tmp_path_factory.mktemp("acc") / "iso10360"
    assert main(["acceptance", "arm-cmm", "--test", "iso10360-12", "--out", str(out)]) == 0
    return json.loads((out / "acceptance.json").read_text())


def test_iso10360_12_before_and_after_calibration(iso10360):
    """The drawing is millimetres off the twin; the calibrated arm measures lengths, locations and
    a sphere to some tens of micrometres (its encoders' 5 urad over a metre's reach and the
    seating's 2 um), every figure far below the drawing's."""
    before, after = iso10360["before"], iso10360["after"]
    for name in ("E_UNI_um", "L_Dia_um", "P_Form_um"):
        assert after[name] < 0.05 * before[name], (name, before[name], after[name])
        assert after[name] < 60.0, (name, after[name])
    assert abs(after["P_Size_um"]) < 10.0 < abs(before["P_Size_um"])
    assert "ISO 10360-12" in iso10360["procedure"]


def test_a_stated_mpe_is_judged_after_calibration(tmp_path, iso10360):
    """An MPE above the figure conforms, one below it does not, and then the command says so by
    its exit status 1."""
    e_uni, l_dia = iso10360["after"]["E_UNI_um"], iso10360["after"]["L_Dia_um"]
    (tmp_path / "c.toml").write_text(
        f"[acceptance.mpe]\nE_UNI_um = {2 * e_uni}\nL_Dia_um = {0.5 * l_dia}\n"
    )
    out = tmp_path / "out"
    argv = ["acceptance", "arm-cmm", "--test", "iso10360-12", "--config", str(tmp_path / "c.toml")]
    assert main(argv + ["--out", str(out)]) == 1
    mpe = json.loads((out / "acceptance.json").read_text())["mpe"]
    assert mpe["E_UNI_um"]["conforms"] and not mpe["L_Dia_um"]["conforms"], mpe


def test_iso9283_before_and_after_calibration(tmp_path):
    """Commanded through the drawing, the robot misses its poses by millimetres; through its
    calibration, by micrometres. Its repeatability is its servo's and the tracker's either way:
    the same within their scatter before and after."""
    out = tmp_path / "iso9283"
    assert main(["acceptance", "arm-cmm", "--test", "iso9283", "--out", str(out)]) == 0
    r = json.loads((out / "acceptance.json").read_text())
    assert r["after"]["AP_mm"] < 0.02 < 0.5 < r["before"]["AP_mm"], r
    assert r["after"]["RP_mm"] == pytest.approx(r["before"]["RP_mm"], rel=0.5), r
    assert [p["pose"] for p in r["after"]["per_pose"]] == ["P1", "P2", "P3", "P4", "P5"]


def test_a_test_that_does_not_apply_is_refused_in_one_line(tmp_path, capsys):
    assert main(["acceptance", "stewart", "--test", "iso9283", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "does not apply to stewart" in err[0], err


def test_iso230_2_on_the_belt_stage_before_and_after_compensation(tmp_path):
    """Commanded at its targets, the belt stage misses them by its maps' millimetres; through its
    fitted maps, by micrometres. Its repeatability is the interferometer's reading and the drive's,
    the same within their scatter either way."""
    out = tmp_path / "iso230"
    assert main(["acceptance", "belt-stage", "--test", "iso230-2", "--out", str(out)]) == 0
    r = json.loads((out / "acceptance.json").read_text())
    for axis in "xy":
        before, after = r["before"], r["after"]
        assert after[f"A_{axis}_um"] < 0.01 * before[f"A_{axis}_um"], (axis, before, after)
        assert after[f"E_{axis}_um"] < 50.0 < 1000.0 < before[f"E_{axis}_um"], (axis, after)
        assert after[f"R_{axis}_um"] == pytest.approx(before[f"R_{axis}_um"], rel=0.6)
        assert len(r[f"targets_{axis}_mm"]) >= 5
