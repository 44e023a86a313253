"""discover through the CLI: discovery.json per docs/formats.md, figures, bad input in one line."""

import json

import numpy as np

from calibench.scenarios.cli import main
from calibench.sim.concealed import arm_recording, stage_recording, write_blinded


def test_stage_discovery_json_follows_the_contract(tmp_path):
    rec, manifest = stage_recording("vision-stage", "backlash", 7)
    path = write_blinded(tmp_path, "rec", rec, manifest)
    assert main(["discover", "vision-stage", str(path), "--out", str(tmp_path / "out")]) == 0
    d = json.loads((tmp_path / "out" / "discovery.json").read_text())
    assert d["scenario"] == "vision-stage" and d["unit"] == "mm" and d["samples"] == len(rec)
    assert set(d["fit"]) == {"rms_nominal", "cv_rms_nominal", "cv_rms_final"}
    e = d["effects"][0]
    assert {"name", "axis", "params", "stderr", "physics", "cv_rms_before", "cv_rms_after"} <= set(
        e
    )
    truth = manifest["effects"][0]
    assert (e["name"], e["axis"]) == ("backlash", truth["axis"])
    # the reversal within 5 standard errors of the truth (stderr from the repeatability)
    assert (
        abs(e["params"]["reversal_mm"] - truth["params"]["reversal_mm"])
        < 5 * e["stderr"]["reversal_mm"]
    )
    assert d["located"][0]["driver"] == f"dir_{truth['axis']}"
    assert (tmp_path / "out" / "discovery.png").stat().st_size > 10_000


def test_arm_discovery(tmp_path):
    rec, manifest = arm_recording("eccentricity", 11)
    path = write_blinded(tmp_path, "arm", rec, manifest)
    assert main(["discover", "arm-cmm", str(path), "--out", str(tmp_path)]) == 0
    d = json.loads((tmp_path / "discovery.json").read_text())
    names = [e["name"] for e in d["effects"]]
    assert names[:2] == ["geometry", "encoder_eccentricity"]
    ecc, se = d["effects"][1]["params"], d["effects"][1]["stderr"]["amplitude_urad"]
    truth = manifest["effects"][0]["params"]
    assert ecc["joint"] == truth["joint"]
    # its size and phase too, within 3 of the standard errors discover reports (a phase's is
    # the amplitude's over the amplitude)
    assert abs(ecc["amplitude_urad"] - truth["amplitude_urad"]) < 3 * se, (ecc, se)
    turn = np.angle(np.exp(1j * (ecc["phase_rad"] - truth["phase_rad"])))  # in (-pi, pi]
    assert abs(turn) < 3 * se / truth["amplitude_urad"], ecc


def test_ur10_compliance_from_mujocos_physics_is_named_with_its_joints(tmp_path):
    """A UR10 whose shoulder and elbow give way (MuJoCo's springs under MuJoCo's gravity), read
    by a tracker in its own frame: discover names joint_compliance of joints 2 and 3 and recovers
    each within 3 std; nothing else."""
    rec, manifest = arm_recording("compliance", 5, arm="ur10")
    path = write_blinded(tmp_path, "ur10", rec, manifest)
    assert main(["discover", "arm-cmm", str(path), "--arm", "ur10", "--out", str(tmp_path)]) == 0
    d = json.loads((tmp_path / "discovery.json").read_text())
    found = {e["params"]["joint"]: e for e in d["effects"] if e["name"] == "joint_compliance"}
    truth = {t["params"]["joint"]: t["params"]["urad_per_nm"] for t in manifest["effects"]}
    assert set(found) == set(truth) == {2, 3}
    for j, c in truth.items():
        assert abs(found[j]["params"]["urad_per_nm"] - c) < 3 * found[j]["stderr"]["urad_per_nm"]
    assert {e["name"] for e in d["effects"]} == {"geometry", "joint_compliance"}


def test_a_gear_harmonic_is_found_and_fit_uses_what_discovery_found(tmp_path):
    """A joint's gear off 8-40 times per turn (not a whole number): discover names transmission
    of that joint at its harmonic; fit --effects discover (on the training rows only) then
    carries the term to held-out rows, which the plain fit cannot."""
    rec, manifest = arm_recording("transmission", 8, n=600, arm="ur10", joint=3)
    truth = manifest["effects"][0]["params"]
    path = write_blinded(tmp_path, "gear", rec, manifest)
    assert (
        main(["discover", "arm-cmm", str(path), "--arm", "ur10", "--out", str(tmp_path / "d")]) == 0
    )
    d = json.loads((tmp_path / "d" / "discovery.json").read_text())
    tr = [e for e in d["effects"] if e["name"] == "transmission"]
    assert len(tr) == 1 and tr[0]["params"]["joint"] == 3
    assert abs(tr[0]["params"]["harmonics"][0] - truth["harmonics"][0]) < 0.05
    assert abs(tr[0]["params"]["amplitude_urad"][0] / truth["amplitude_urad"][0] - 1) < 0.25
    held = {}
    for label, extra in (("plain", []), ("found", ["--effects", "discover"])):
        out = tmp_path / label
        assert (
            main(
                [
                    "fit",
                    "arm-cmm",
                    str(path),
                    "--arm",
                    "ur10",
                    "--model",
                    "geometry",
                    "--holdout",
                    "0.3",
                    "--out",
                    str(out),
                    *extra,
                ]
            )
            == 0
        )
        held[label] = json.loads((out / "fit.json").read_text())["holdout"]["gear.csv"]["mean_mm"]
    assert held["found"] < 0.03 < held["plain"], (
        held
    )  # the reference's 10 um noise: 0.016 mm in 3-D


def test_a_gear_harmonic_whose_phase_each_session_sets_is_found_per_recording(tmp_path):
    """Two sessions of one UR10 whose joint-2 gear is off 17.3 times per turn, the phase set anew
    at power-up (a motor-side error): discover on both names a transmission of joint 2 with a
    phase per recording, at the harmonic within 0.05 cycles per turn and each session's amplitude
    within 25 %; fit --effects discover carries both sessions' terms to their held-out rows (the
    10 um reference: 0.016 mm in 3-D), which a shared phase cannot."""
    paths, amps = [], []
    for seed, phase in ((21, 0.3), (22, 2.4)):
        rec, manifest = arm_recording(
            "transmission", seed, n=500, arm="ur10", joint=2, harmonic=17.3, phase_rad=phase
        )
        paths.append(write_blinded(tmp_path, f"s{seed}", rec, manifest))
        amps.append(manifest["effects"][0]["params"]["amplitude_urad"][0])
    assert (
        main(
            ["discover", "arm-cmm", *map(str, paths), "--arm", "ur10", "--out", str(tmp_path / "d")]
        )
        == 0
    )
    d = json.loads((tmp_path / "d" / "discovery.json").read_text())
    tr = [e for e in d["effects"] if e["name"] == "transmission"]
    assert [(e["params"]["joint"], e["params"].get("per_recording")) for e in tr] == [(2, True)], tr
    assert abs(tr[0]["params"]["harmonics"][0] - 17.3) < 0.05
    # held out whole, each session is better with its own phase fitted on a fifth of its rows
    assert tr[0]["belongs"] == "session"
    assert tr[0]["new_session_rms"]["with"] < tr[0]["new_session_rms"]["without"]
    for found, truth in zip(tr[0]["params"]["amplitude_urad_by_recording"], amps, strict=True):
        assert abs(found / truth - 1) < 0.25, (found, truth)
    out = tmp_path / "fit"
    assert (
        main(
            [
                "fit",
                "arm-cmm",
                *map(str, paths),
                "--arm",
                "ur10",
                "--model",
                "geometry",
                "--holdout",
                "0.3",
                "--effects",
                "discover",
                "--out",
                str(out),
            ]
        )
        == 0
    )
    fit = json.loads((out / "fit.json").read_text())
    assert "transmission2_rec2" in " ".join(fit["effects_from"]["terms"])
    assert all(h["mean_mm"] < 0.03 for h in fit["holdout"].values()), fit["holdout"]


def test_a_gear_harmonic_the_sessions_share_is_not_split_per_recording():
    """The same gear in two sessions with one phase and amplitude: one transmission for both (a
    phase per recording would fit noise)."""
    from calibench.scenarios.arm_cmm.discovery import discover_arm

    recs = [
        arm_recording(
            "transmission",
            seed,
            n=500,
            arm="ur10",
            joint=2,
            harmonic=17.3,
            phase_rad=1.0,
            amplitude_urad=220.0,
        )[0]
        for seed in (21, 22)
    ]
    d, _ = discover_arm(recs, arm="ur10")
    tr = [e for e in d["effects"] if e["name"] == "transmission"]
    assert [(e["params"]["joint"], e["params"].get("per_recording")) for e in tr] == [(2, None)], tr
    assert abs(tr[0]["params"]["amplitude_urad"][0] / 220.0 - 1) < 0.25


def test_a_tool_guessed_100_mm_off_leaves_no_structure_behind():
    """The arm file's tool is a first guess (docs/formats.md: always estimated). A measured point
    100 mm beside it changes every joint's lever arm, and discovery's candidates are linear: taken
    at the drawing, they left 29x the noise on such a recording and called it explained. Taken at
    the geometry's solution, a recording with nothing else in it (MuJoCo's UR10, its default
    as-built errors) is explained to its noise: the held-out RMS per coordinate within 10 % of the
    10 um the tracker adds (600 x 3 values, 31 parameters fitted in each fold), and nothing else
    named."""
    import numpy as np

    from calibench.recordings import ArmRecording
    from calibench.scenarios.arm_cmm.discovery import discover_arm
    from calibench.scenes.arm_cmm import load_arm
    from calibench.sim.arm_cmm import ArmSim, ArmTruth, default_errors

    arm = load_arm("ur10")
    delta = np.array(default_errors(arm))
    delta[-3:] += (80.0, -50.0, 60.0)  # the probe beside the flange, not on its axis
    truth = ArmTruth(delta=tuple(delta))
    sim = ArmSim(arm, truth)
    rng = np.random.default_rng(3)
    q = sim.random_postures(600, rng)
    R, p = truth.tracker2base()
    noise_mm = 0.010
    xyz = (sim.probe_mm(q) - p) @ R + rng.normal(0, noise_mm, q.shape[:1] + (3,))
    d, _ = discover_arm(ArmRecording(q, xyz), arm=arm)
    assert [e["name"] for e in d["effects"]] == ["geometry"], d["summary"]
    assert d["fit"]["cv_rms_final"] < 1.1 * noise_mm, d["fit"]


def test_postures_that_turn_one_joint_only_leave_the_geometry_nothing_to_claim():
    """Joint 1 alone turning: the tracker's frame and the tool absorb every kinematic error, so
    there is no geometry candidate (it used to end in an internal error), and nothing is named."""
    import numpy as np

    from calibench.recordings import ArmRecording
    from calibench.scenarios.arm_cmm.discovery import discover_arm
    from calibench.scenes.arm_cmm import load_arm
    from calibench.sim.arm_cmm import ArmSim, ArmTruth

    arm = load_arm("ur10")
    truth = ArmTruth()
    rng = np.random.default_rng(4)
    q = np.tile(np.radians([0.0, -60.0, 70.0, -40.0, 80.0, 20.0]), (200, 1))
    q[:, 0] = rng.uniform(-np.pi, np.pi, 200)
    R, p = truth.tracker2base()
    xyz = (ArmSim(arm, truth).probe_mm(q) - p) @ R + rng.normal(0, 0.010, (200, 3))
    d, _ = discover_arm(ArmRecording(q, xyz), arm=arm)
    assert d["effects"] == [], d["summary"]


def test_an_eccentric_shoulder_encoder_is_not_called_compliance():
    """Joint 2's gravity torque is nearly a sinusoid of its own angle; the other joints' angles
    tell the two apart."""
    from calibench.scenarios.arm_cmm.discovery import discover_arm

    for arm in ("arm-cmm", "ur10"):
        rec, manifest = arm_recording("eccentricity", 6, arm=arm, joint=2)
        d, _ = discover_arm(rec, arm=arm)
        names = [
            (e["name"], e["params"].get("joint")) for e in d["effects"] if e["name"] != "geometry"
        ]
        assert names == [("encoder_eccentricity", 2)], (arm, names)


def test_a_pedestal_warming_up_is_a_drift_of_the_points_in_time():
    """The arm's pedestal rising as a first-order lag from power-on (an exponential in time no
    candidate writes down), under Gaussian noise: named ``thermal_drift`` driven by time and
    nothing else, upward, at the warm-up's mean slope over the recording (a slope and a bend
    fitted to an exponential: within a factor of 1.5), and not along x or y beyond 4 std."""
    import numpy as np

    from calibench.scenarios.arm_cmm.discovery import discover_arm

    rec, manifest = arm_recording("pedestal_warmup", 21)
    d, _ = discover_arm(rec)
    t = manifest["effects"][0]["params"]
    found = [e for e in d["effects"] if e["name"] != "geometry"]
    assert [e["name"] for e in found] == ["thermal_drift"], found
    p, s = found[0]["params"], found[0]["stderr"]
    span_h = float(np.ptp(rec.t_s)) / 3600
    mean_slope = t["rise_mm"] * (1 - np.exp(-span_h * 3600 / t["tau_s"])) / span_h
    assert 1 / 1.5 < p["z_mm_per_h"] / mean_slope < 1.5, (p, mean_slope)
    assert abs(p["x_mm_per_h"]) < 4 * s["x_mm_per_h"] and abs(p["y_mm_per_h"]) < 4 * s["y_mm_per_h"]


def test_thermal_expansion_without_a_temperature_change_is_called_confounded(tmp_path):
    """A null belt-stage recording: nothing concealed, so nothing located either (its 12 tests of
    a residual against a driver at p <= 0.01 each: at most 12 % of nulls locate anything by
    chance, and this seed is not one of them), and thermal expansion is called confounded."""
    rec, manifest = stage_recording("belt-stage", "null", 3)
    from calibench.scenarios.stages.discovery import discover_stage

    d, _ = discover_stage("belt-stage", rec)
    assert d["located"] == [], d["located"]
    assert any(
        c["effect"] == "thermal_expansion" and "several K" in c["experiment"]
        for c in d["confounded"]
    )


def test_bad_recordings_get_one_line(tmp_path, capsys, monkeypatch):
    # the one line alone: a discovery past 10 s (a busy machine) would say progress lines first
    monkeypatch.setenv("CALIBENCH_PROGRESS", "off")
    bad = tmp_path / "bad.csv"
    bad.write_text("x_cmd_mm,y_cmd_mm,x_meas_mm\n1,2,3\n")
    assert main(["discover", "belt-stage", str(bad), "--out", str(tmp_path)]) == 2
    assert "missing column(s) y_meas_mm" in capsys.readouterr().err
    nan = tmp_path / "nan.csv"
    nan.write_text(
        "x_cmd_mm,y_cmd_mm,x_meas_mm,y_meas_mm\n" + "\n".join(f"{i},0,{i},nan" for i in range(30))
    )
    assert main(["discover", "belt-stage", str(nan), "--out", str(tmp_path)]) == 2
    assert main(["discover", "stewart", str(nan), "--out", str(tmp_path)]) == 2
    line = tmp_path / "line.csv"  # every station on one line: the error map is not determined
    line.write_text(
        "x_cmd_mm,y_cmd_mm,x_meas_mm,y_meas_mm\n" + "\n".join(f"{i},0,{i},0" for i in range(30))
    )
    assert main(["discover", "belt-stage", str(line), "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 3 and all(e.startswith("calibench: ") for e in err)


def test_paper_belt_stage_residual_is_table_3_and_lives_in_y(real_data):
    """The seed paper's measured tables with its quadratic as the simulation: the residual RMS is
    Table 3's, sqrt((31.96 + 24.08) / 242) = 0.4812 mm (to its printed digits), and the located
    structure is the Y error against y."""
    from calibench.scenarios.stages.discovery import discover_stage, paper_belt_recording

    d, _ = discover_stage(
        "belt-stage", paper_belt_recording(real_data / "seed_belt_stage"), 0, "columns"
    )
    assert abs(d["fit"]["rms_nominal"] - (31.96 + 24.08) ** 0.5 / 242**0.5) < 2e-4
    top = d["located"][0]
    assert (top["signal"], top["driver"]) == ("y_meas - y_sim", "y")


def test_what_is_left_is_judged_against_the_noise_floor(monkeypatch):
    """A null recording ends at its noise floor and says so; the same machine with lost motion
    and no candidate allowed to find it (the candidate list emptied) must not stop silently: it
    reports the held-out RMS against the floor from the fastest repeats, after the effects, and
    where what is left lives (the direction of approach)."""
    import calibench.scenarios.stages.discovery as disc

    null, _ = stage_recording("vision-stage", "null", 5)
    d, _ = disc.discover_stage("vision-stage", null)
    assert d["located"] == [], d["located"]  # nothing concealed, nothing located
    assert d["verdict"].startswith("nothing missing") and "um noise floor from" in d["verdict"]
    rec, _ = stage_recording("vision-stage", "backlash", 7)
    monkeypatch.setattr(disc, "stage_candidates", lambda drivers: [])
    monkeypatch.setattr(disc, "polynomial_candidates", lambda axis, deg: [])
    monkeypatch.setattr(disc, "find_nonsmooth", lambda *a, **k: None)
    d, _ = disc.discover_stage("vision-stage", rec)
    assert d["verdict"].startswith("unexplained:") and "um noise floor from" in d["verdict"]
    assert d["fit"]["cv_rms_final"] > 1.5 * d["noise_floor"]["sigma_mm"]
    assert d["unexplained"]["driver"].startswith("dir_"), d["unexplained"]


def test_an_effect_one_session_alone_shows_does_not_belong_to_the_machine(tmp_path):
    """Three sessions of one UR10 in their own frames; only the first has an eccentric encoder
    on joint 4 (its disc remounted between sessions, say). Pooled, the eccentricity cuts the
    held-out RMS of the postures of that session, enough to be accepted; held out whole, a
    session without it is worse with the others' eccentricity: discovery drops it and says it
    belongs to the sessions it was found in. The machine's geometry stays."""
    paths = []
    for kind, seed in (("eccentricity", 31), ("null", 32), ("null", 33)):
        rec, manifest = arm_recording(kind, seed, n=400, arm="ur10", joint=4)
        paths.append(write_blinded(tmp_path, f"s{seed}", rec, manifest))
    out = tmp_path / "d"
    assert main(["discover", "arm-cmm", *map(str, paths), "--arm", "ur10", "--out", str(out)]) == 0
    d = json.loads((out / "discovery.json").read_text())
    assert [e["name"] for e in d["effects"]] == ["geometry"], d["effects"]
    assert (
        "belongs to the sessions it was found in"
        in d["not_accepted"]["encoder_eccentricity:joint4"]
    )
