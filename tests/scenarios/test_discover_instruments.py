"""discover probe-scanner and discover stewart through the CLI: blinded recordings written as the
docs/formats.md's CSV, read back, the concealed effect named with its parameters within a tolerance
derived from the standard error discover reports; nothing named on a null."""

import json
import tomllib

import numpy as np

from calibench.recordings import load_scanner_csv, load_stewart_csv
from calibench.scenarios.cli import main
from calibench.sim.concealed import scanner_recording, stewart_recording, write_blinded


def _discover(tmp_path, scenario, rec, manifest):
    path = write_blinded(tmp_path, "rec", rec, manifest)
    assert main(["discover", scenario, str(path), "--out", str(tmp_path / "out")]) == 0
    assert (tmp_path / "out" / "discovery.png").stat().st_size > 10_000
    return json.loads((tmp_path / "out" / "discovery.json").read_text())


def test_scanner_csv_round_trip(tmp_path):
    rec, manifest = scanner_recording("null", 3, turns=2)
    back = load_scanner_csv(write_blinded(tmp_path, "s", rec, manifest))
    assert np.array_equal(back.turn, rec.turn)
    assert np.allclose(back.theta_rad, rec.theta_rad, atol=1e-12) and np.allclose(
        back.rho_mm, rec.rho_mm, atol=1e-9
    )


def test_stewart_csv_round_trip(tmp_path):
    rec, manifest = stewart_recording("null", 3, n_poses=30)
    back = load_stewart_csv(write_blinded(tmp_path, "p", rec, manifest))
    assert np.allclose(back.readings_mm, rec.readings_mm, rtol=1e-9, atol=0)
    assert np.allclose(back.R, rec.R, atol=1e-9) and np.allclose(back.t_mm, rec.t_mm, atol=1e-6)
    assert np.array_equal(back.direction, rec.direction) and np.allclose(back.load_n, rec.load_n)


def test_scanner_eccentricity_and_runout_named_with_their_sizes(tmp_path):
    rec, manifest = scanner_recording("combined", 1017)
    d = _discover(tmp_path, "probe-scanner", rec, manifest)
    found = {e["name"]: e for e in d["effects"]}
    truth = {t["name"]: t["params"] for t in manifest["effects"]}
    assert set(found) == set(truth)
    ecc, run, sc = found["encoder_eccentricity"], found["runout"], found["scale"]
    # each within 5 of its standard errors, plus the quantised probe's 2 % of model error
    assert abs(
        ecc["params"]["amplitude_urad"] - truth["encoder_eccentricity"]["amplitude_urad"]
    ) < (
        5 * ecc["stderr"]["amplitude_urad"] + 0.02 * truth["encoder_eccentricity"]["amplitude_urad"]
    )
    assert run["params"]["harmonic"] == truth["runout"]["harmonic"]
    assert (
        abs(run["params"]["amplitude_mm"] - truth["runout"]["amplitude_mm"])
        < 5 * run["stderr"]["amplitude_mm"]
    )
    assert (
        abs(sc["params"]["ppm"] - truth["scale"]["ppm"])
        < 5 * sc["stderr"]["ppm"] + 0.02 * truth["scale"]["ppm"]
    )
    assert d["fit"]["cv_rms_final"] < 0.5 * d["fit"]["cv_rms_nominal"]
    assert d["verdict"].startswith("the accepted effects explain")
    # a fourfold runout cannot be seen on a square: discover says so rather than search it
    assert any(c["effect"] == "runout" and "square" in c["with"] for c in d["confounded"])


def test_scanner_nick_is_nonsmooth_where_it_is(tmp_path):
    rec, manifest = scanner_recording("bump", 1021)
    d = _discover(tmp_path, "probe-scanner", rec, manifest)
    (e,) = d["effects"]
    t = manifest["effects"][0]["params"]
    assert e["name"] == "nonsmooth"
    assert abs((e["params"]["theta_deg"] - t["theta_deg"] + 180) % 360 - 180) < 3 * max(
        t["width_deg"], 1.0
    )


def test_scanner_null_names_nothing(tmp_path):
    rec, manifest = scanner_recording("null", 29)
    d = _discover(tmp_path, "probe-scanner", rec, manifest)
    assert d["effects"] == [] and d["verdict"].startswith("nothing missing")


def test_stewart_backlash_on_its_leg(tmp_path):
    rec, manifest = stewart_recording("backlash", 1019)
    d = _discover(tmp_path, "stewart", rec, manifest)
    names = [(e["name"], e["params"].get("leg")) for e in d["effects"]]
    t = manifest["effects"][0]["params"]
    assert names == [("geometry", None), ("backlash", t["leg"])]
    b = d["effects"][1]
    assert abs(b["params"]["reversal_mm"] - t["reversal_mm"]) < 5 * b["stderr"]["reversal_mm"]
    # located before it is named: the leg, by its direction of approach, and nothing on the others
    assert {(x["leg"], x["driver"]) for x in d["located"]} == {(t["leg"], "direction")}


def test_stewart_compliance_under_mujocos_statics(tmp_path):
    """Legs shortened by the axial forces MuJoCo's statics put on them (weights and payloads):
    one compliance for the six, within 5 standard errors and the legs' 5 % spread."""
    rec, manifest = stewart_recording("compliance", 1024)
    d = _discover(tmp_path, "stewart", rec, manifest)
    c = [e for e in d["effects"] if e["name"] == "leg_compliance"]
    assert [e["name"] for e in d["effects"]] == ["geometry", "leg_compliance"]
    truth = manifest["effects"][0]["params"]["um_per_n"]
    assert abs(c[0]["params"]["um_per_n"] - truth) < 5 * c[0]["stderr"]["um_per_n"] + 0.05 * truth


def test_stewart_thermal_growth_is_found_and_leaves_the_noise(tmp_path, stewart_null_rms):
    """A leg warming over the recording: found on its leg at its rate, located against
    temperature and time, and what is left in discover's folds (in-sample for the structure: a
    fresh recording's score is the unwritten suite's) is the instruments' noise, under 1.5 times
    a null recording's (``stewart_null_rms``). Repeats are grouped by the legs' readings (what
    was commanded): here the warming leg's readings move with the temperature, so its visits
    at other temperatures are other commands, and the drift cannot hide in the repeatability."""
    rec, manifest = stewart_recording("thermal", 1020)
    d = _discover(tmp_path, "stewart", rec, manifest)
    t = manifest["effects"][0]["params"]
    e = d["effects"][1]
    assert (e["name"], e["params"]["leg"]) == ("thermal_expansion", t["leg"])
    assert abs(e["params"]["ppm_per_k"] - t["ppm_per_k"]) < 5 * e["stderr"]["ppm_per_k"]
    assert d["fit"]["cv_rms_final"] < 1.5 * stewart_null_rms
    assert {(x["leg"], x["driver"]) for x in d["located"]} == {
        (t["leg"], "temp_c"),
        (t["leg"], "t_s"),
    }


def test_stewart_sensor_warming_up_is_a_drift_in_time_on_its_leg(tmp_path, stewart_null_rms):
    """A leg's length sensor settling from power-on as a first-order lag (an exponential in
    time that no candidate writes down), under Gaussian noise: named ``thermal_drift`` on that
    leg and nothing else, not the leg's ``thermal_expansion`` (the temperature only wanders),
    and what is left in discover's folds is the instruments' noise (as the thermal leg's, above)."""
    rec, manifest = stewart_recording("sensor_warmup", 1031)
    d = _discover(tmp_path, "stewart", rec, manifest)
    t = manifest["effects"][0]["params"]
    assert [(e["name"], e["params"].get("leg")) for e in d["effects"]] == [
        ("geometry", None),
        ("thermal_drift", t["leg"]),
    ]
    # the warm-up's mean slope over the recording, against the one found (a slope and a bend
    # fitted to an exponential: its slope at mid-recording within a factor of two of the mean)
    span_h = float(np.ptp(rec.t_s)) / 3600
    mean_slope = t["shift_mm"] * (1 - np.exp(-span_h * 3600 / t["tau_s"])) / span_h
    assert 0.5 < d["effects"][1]["params"]["mm_per_h"] / mean_slope < 2.0
    assert d["fit"]["cv_rms_final"] < 1.5 * stewart_null_rms


def test_a_tracker_reading_through_warming_air_is_a_drift_of_its_poses(tmp_path, stewart_null_rms):
    """A tracker 5-10 m away whose air compensation stays at the start while the room warms
    3-6 K: every distance it measures reads long by 0.93 ppm per K (the air's refractive index),
    a scale about the tracker that no candidate writes down; to the platform it is a shift along
    the line of sight. Named ``thermal_drift`` of the tracker's poses (no leg's own effect), its
    slope the index times the tracker's distance: within 3 of its standard errors and 15 % (the
    platform stands up to 0.8 m off the base's origin, along which the distance is drawn)."""
    rec, manifest = stewart_recording("tracker_air", 1041)
    d = _discover(tmp_path, "stewart", rec, manifest)
    t = manifest["effects"][0]["params"]
    assert [(e["name"], e["params"].get("tracker")) for e in d["effects"]] == [
        ("geometry", None),
        ("thermal_drift", True),
    ], d["effects"]
    e = d["effects"][1]
    want = t["ppm_per_k"] * 1e-6 * t["range_mm"]
    # it follows the logged air: the temperature's candidate, not time's
    assert abs(e["params"]["mm_per_k"] - want) < 3 * e["stderr"]["mm_per_k"] + 0.15 * want, e
    # reading long moves the poses away from the tracker, along its line of sight (the tracker
    # stands at the registered frame's origin, in the base frame)
    R, tf = np.array(d["tracker_frame"]["R"]), np.array(d["tracker_frame"]["t_mm"])
    away = np.mean(rec.t_mm @ R.T + tf, axis=0) - tf
    slope = np.array([e["params"][f"{a}_mm_per_k"] for a in "xyz"])
    assert slope @ away / (np.linalg.norm(slope) * np.linalg.norm(away)) > 0.9, (slope, away)
    assert d["fit"]["cv_rms_final"] < 1.5 * stewart_null_rms


def test_stewart_pitch_located_along_its_leg(tmp_path):
    """A screw's pitch error of a few mm shows as structure along that leg's length only."""
    rec, manifest = stewart_recording("pitch", 2)
    d = _discover(tmp_path, "stewart", rec, manifest)
    t = manifest["effects"][0]["params"]
    assert {(x["leg"], x["driver"]) for x in d["located"]} == {(t["leg"], "length")}
    assert [(e["name"], e["params"].get("leg")) for e in d["effects"]] == [
        ("geometry", None),
        ("periodic", t["leg"]),
    ]


def test_stewart_null_names_and_locates_nothing(tmp_path):
    rec, manifest = stewart_recording("null", 4)
    d = _discover(tmp_path, "stewart", rec, manifest)
    assert [e["name"] for e in d["effects"]] == ["geometry"] and d["located"] == []


def test_scanner_twin_updated_and_replayed(tmp_path):
    """discover --twin writes the found effects as the scanner's simulation parameters; discover
    --config replays the recording with that twin in MuJoCo: its residual (simulated, not fitted)
    is at the held-out level the discovery reported, within 20 %, and nothing is left to find."""
    rec, manifest = scanner_recording("combined", 1017)
    path = write_blinded(tmp_path, "rec", rec, manifest)
    twin = tmp_path / "twin.toml"
    assert (
        main(
            [
                "discover",
                "probe-scanner",
                str(path),
                "--twin",
                str(twin),
                "--out",
                str(tmp_path / "a"),
            ]
        )
        == 0
    )
    found = json.loads((tmp_path / "a" / "discovery.json").read_text())
    assert "runout_harmonics" in twin.read_text() and "probe_scale_ppm" in twin.read_text()
    assert (
        main(
            [
                "discover",
                "probe-scanner",
                str(path),
                "--config",
                str(twin),
                "--twin",
                str(tmp_path / "again.toml"),
                "--out",
                str(tmp_path / "b"),
            ]
        )
        == 0
    )
    replayed = json.loads((tmp_path / "b" / "discovery.json").read_text())
    assert replayed["effects"] == []
    # updated again with nothing found, the twin keeps what the first discovery wrote into it
    first, again = (
        tomllib.loads(t.read_text())["probe-scanner"]["truth"]
        for t in (twin, tmp_path / "again.toml")
    )
    for key in ("runout_harmonics", "runout_mm", "runout_phase_rad", "probe_scale_ppm"):
        assert np.allclose(again[key], first[key], rtol=1e-12, atol=0), key
    assert abs(replayed["fit"]["cv_rms_nominal"] / found["fit"]["cv_rms_final"] - 1) < 0.2
    assert (
        found["fit"]["cv_rms_nominal"] > 2 * found["fit"]["cv_rms_final"]
    )  # the twin alone was far off
    # the same file drives a run: the scanner simulated with what was found
    assert main(
        ["run", "probe-scanner", "--config", str(twin), "--no-rrd", "--out", str(tmp_path / "r")]
    ) in (0, 1)


def test_a_twin_that_cannot_be_written_is_one_line(tmp_path, capsys, monkeypatch):
    # the one line alone: a discovery past 10 s (a busy machine) would say progress lines first
    monkeypatch.setenv("CALIBENCH_PROGRESS", "off")
    rec, manifest = stewart_recording("null", 3, n_poses=30)
    path = write_blinded(tmp_path, "p", rec, manifest)
    assert (
        main(["discover", "stewart", str(path), "--twin", str(tmp_path / "no" / "such" / "t.toml")])
        == 2
    )
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "cannot write the twin" in err[0]
