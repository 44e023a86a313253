"""``calibench fit arm-cmm`` on arms of unusual shape, from their ARM.toml: a heavy arm whose
compliance columns dwarf its geometry's, a SCARA whose axes are all parallel. Recordings from
the MuJoCo twin of each, in docs/formats.md's CSV format."""

import json

import numpy as np

from calibench.estimators.rotations import rotvec_to_matrix
from calibench.recordings import ArmRecording
from calibench.scenarios.cli import main
from calibench.sim.arm_cmm import ArmSim, ArmTruth

NOISE_MM = 0.02


SCARA = """name = "scara"
convention = "dh"
[[joint]]
a_mm = 400.0
d_mm = 300.0
alpha_deg = 0.0
[[joint]]
a_mm = 350.0
d_mm = 0.0
alpha_deg = 0.0
[[joint]]
a_mm = 0.0
d_mm = 0.0
alpha_deg = 0.0
[tool]
offset_mm = [60.0, 0.0, -100.0]
"""


# A KR 210's proportions, 900 kg: a_mm, d_mm, alpha_deg, theta_deg, range_deg, mass_kg, com_mm per
# joint
HEAVY_JOINTS = [
    (350.0, 675.0, -90.0, 0.0, (-170, 170), 400.0, (-150.0, 100.0, 0.0)),
    (1150.0, 0.0, 0.0, -90.0, (-60, 60), 200.0, (-600.0, 0.0, 150.0)),
    (41.0, 0.0, -90.0, 0.0, (-120, 120), 180.0, (0.0, 0.0, 150.0)),
    (0.0, 1200.0, 90.0, 0.0, (-170, 170), 60.0, (0.0, 300.0, 0.0)),
    (0.0, 0.0, -90.0, 0.0, (-120, 120), 20.0, (0.0, 0.0, 30.0)),
    (0.0, 215.0, 0.0, 0.0, (-170, 170), 5.0, (0.0, 0.0, -20.0)),
]


def _arm_toml(name: str, joints, tool_mm, tool_kg: float) -> str:
    """An ARM.toml (docs/formats.md, "Arm descriptions") from one row per joint, as
    :data:`HEAVY_JOINTS`."""
    text = f'name = "{name}"\nconvention = "dh"\n'
    for a, d, alpha, theta, (lo, hi), m, com in joints:
        text += (
            f"[[joint]]\na_mm = {a}\nd_mm = {d}\nalpha_deg = {alpha}\ntheta_deg = {theta}\n"
            f"range_deg = [{lo}.0, {hi}.0]\nmass_kg = {m}\ncom_mm = {list(com)}\n"
        )
    return text + f"[tool]\noffset_mm = {list(tool_mm)}\nmass_kg = {tool_kg}\n"


def test_a_heavy_arms_compliance_does_not_crowd_out_its_geometry(tmp_path):
    """A 900 kg arm (a KR 210's proportions): a compliance's column, its gravity torque (5 kN m)
    times a typical 10 urad / N m, is 25 times an angle error's. The identifiable basis measured
    its tolerance against the largest column, so --model physics dropped kinematic errors that
    --model geometry determines (da5 and dd5 here, with the wrist's ranges of a KR 210). Now the
    tolerance is measured against the largest geometric column, and both keep the same geometry."""
    (tmp_path / "heavy.toml").write_text(_arm_toml("heavy", HEAVY_JOINTS, (12.5, -8.3, 135.2), 8.0))
    sim = ArmSim(
        str(tmp_path / "heavy.toml"),
        ArmTruth(stiffness_nm_per_rad=(np.inf, 5e7, 3e7, np.inf, np.inf, np.inf)),
    )
    rng = np.random.default_rng(5)
    q = sim.random_postures(600, rng)
    R, t = rotvec_to_matrix(np.array([0.01, 0.02, 2.0])), np.array([3000.0, -1500.0, 200.0])
    ArmRecording(q, sim.probe_mm(q) @ R.T + t + rng.normal(0, NOISE_MM, (600, 3))).to_csv(
        tmp_path / "h.csv"
    )
    kept = {}
    for model in ("geometry", "physics"):
        out = tmp_path / model
        assert (
            main(
                [
                    "fit",
                    "arm-cmm",
                    str(tmp_path / "h.csv"),
                    "--arm",
                    str(tmp_path / "heavy.toml"),
                    "--model",
                    model,
                    "--out",
                    str(out),
                ]
            )
            == 0
        )
        names = [p["name"] for p in json.loads((out / "fit.json").read_text())["parameters"]]
        kept[model] = {n for n in names if not n.startswith("compliance")}
    assert kept["physics"] == kept["geometry"], kept


def test_an_arm_whose_axes_are_all_parallel_holds_its_tools_height(tmp_path):
    """A SCARA's axes are all vertical: the tool's height moves the data as the base's does. The
    fit holds tool_z at the drawing's value, says so, and fits to the tracker's noise (it was
    refused as singular)."""
    (tmp_path / "scara.toml").write_text(SCARA)
    sim = ArmSim(str(tmp_path / "scara.toml"), ArmTruth())
    rng = np.random.default_rng(4)
    q = sim.random_postures(300, rng)
    R, t = rotvec_to_matrix(np.array([0.002, -0.001, 0.7])), np.array([1500.0, -300.0, 80.0])
    ArmRecording(q, sim.probe_mm(q) @ R.T + t + rng.normal(0, NOISE_MM, (300, 3))).to_csv(
        tmp_path / "s.csv"
    )
    out = tmp_path / "out"
    assert (
        main(
            [
                "fit",
                "arm-cmm",
                str(tmp_path / "s.csv"),
                "--arm",
                str(tmp_path / "scara.toml"),
                "--out",
                str(out),
            ]
        )
        == 0
    )
    fit = json.loads((out / "fit.json").read_text())
    held = {d["name"]: d["why"] for d in fit["dropped"]}
    assert "base_z" in held["tool_z"] and "held at the drawing" in held["tool_z"]
    # 3-D RMS of a 3-coordinate Gaussian less the fitted parameters' share: within 15 % of sqrt(3)
    # sigma
    assert abs(fit["fit"]["rms_mm"] / (np.sqrt(3) * NOISE_MM) - 1) < 0.15, fit["fit"]


def _three_sessions(tmp_path, noise=0.02):
    """Three sessions (300 postures each) of the twin's compliant UR10, each in its own tracker
    frame, with Gaussian tracker noise of ``noise`` mm per coordinate: their CSV paths."""
    sim = ArmSim("ur10", ArmTruth(stiffness_nm_per_rad=(np.inf, 2.0e5, 1.5e5) + (np.inf,) * 3))
    rng = np.random.default_rng(5)
    paths = []
    for k in range(3):
        q = sim.random_postures(300, rng)
        R, t = rotvec_to_matrix(rng.normal(0, 1.0, 3)), rng.uniform(-2000, 2000, 3)
        y = sim.probe_mm(q) @ R.T + t + rng.normal(0, noise, q.shape[:1] + (3,))
        paths.append(tmp_path / f"session{k}.csv")
        ArmRecording(q + rng.normal(0, 2e-6, q.shape), y).to_csv(paths[-1])
    return paths


def test_leave_one_session_out_scores_each_session_by_the_others(tmp_path):
    """Three sessions of the twin's compliant UR10, each in its own tracker frame: every session
    scored by a calibration on the other two, its frame registered on a fifth of its rows. The
    model is right, so each score is the tracker's noise: the mean 3-D error of a Gaussian of
    0.02 mm per coordinate is 0.032 mm, and the registration on ~60 rows adds a few per cent."""
    paths = _three_sessions(tmp_path)
    out = tmp_path / "loso"
    args = ["fit", "arm-cmm", *map(str, paths), "--arm", "ur10", "--leave-one-out"]
    assert main([*args, "--out", str(out)]) == 0
    table = json.loads((out / "fit.json").read_text())["leave_one_out"]
    assert set(table) == {p.name for p in paths}
    for name, e in table.items():
        assert name not in e["trained_on"] and len(e["trained_on"]) == 2
        assert not e["in_sample"] and e["samples"] == 240  # 300 rows, 60 registered
        assert 0.8 * 0.032 < e["mean_mm"] < 1.25 * 0.032, (name, e)
        assert (out / name.removesuffix(".csv") / "fit.json").exists()


def test_the_registration_floor_is_in_sample_and_below_the_held_out_score(tmp_path):
    """The floor under leave-one-session-out (``register_on_scored``): each left-out session's
    frame fitted on every row, the scored ones too. It is written as in-sample, never as a
    result, scores the same 240 rows, and sits just below the fifth-registered score: a frame
    fitted on 60 rows errs by 6 parameters' worth over 180 coordinates, about 3 % of the squared
    error on the rows it did not see (1.7 % of the RMS), which a frame fitted on all 300 mostly
    removes. The model is right here, so there is nothing else to gain."""
    from calibench.scenarios.arm_cmm.sessions import leave_one_session_out

    paths = _three_sessions(tmp_path)
    held = leave_one_session_out(paths, "ur10", None, tmp_path / "held")["leave_one_out"]
    floor = leave_one_session_out(paths, "ur10", None, tmp_path / "floor", None, True)
    for name, e in floor["leave_one_out"].items():
        assert e["in_sample"] and e["samples"] == held[name]["samples"] == 240
        assert 0.95 * held[name]["rms_mm"] < e["rms_mm"] < held[name]["rms_mm"], (name, e)


def test_a_harmonic_whose_phase_each_session_sets_is_refitted_on_the_registration_rows(tmp_path):
    """Three sessions of the twin's UR10 whose joint 2 is off by 300 urad at 17.3 cycles per
    turn, its phase set anew at each power-up (the links at the reading less the error; MuJoCo's
    kinematics then put the tool). Calibrated on two with that harmonic per session
    (``--effects``), a left-out session's phase is unknown: it is fitted beside the frame on the
    fifth of its rows that register it, and the other rows then score at the tracker's noise
    (without it they would carry the harmonic: about 0.3 mm). The coefficients recovered are the
    session's own, within their noise."""
    noise, amp, h = 0.02, 300e-6, 17.3
    sim = ArmSim("ur10", ArmTruth())
    rng = np.random.default_rng(8)
    paths, phases = [], (0.4, 2.5, 4.6)
    for k, ph in enumerate(phases):
        q = sim.random_postures(300, rng)
        link = q.copy()
        link[:, 1] -= amp * np.sin(h * q[:, 1] + ph)
        R, t = rotvec_to_matrix(rng.normal(0, 1.0, 3)), rng.uniform(-2000, 2000, 3)
        y = sim.point_mm(link) @ R.T + t + rng.normal(0, noise, (300, 3))
        paths.append(tmp_path / f"session{k}.csv")
        ArmRecording(q, y).to_csv(paths[-1])
    effects = {
        "scenario": "arm-cmm",
        "effects": [
            {
                "name": "transmission",
                "params": {"joint": 2, "harmonics": [h], "per_recording": True},
            }
        ],
        # chosen elsewhere (a harmonic the user knows of), on none of these sessions' rows
        "provenance": {
            "recordings": [{"file": "bench.csv", "sha256": "0" * 64, "rows": {"chose": [[0, 99]]}}]
        },
    }
    (tmp_path / "effects.json").write_text(json.dumps(effects))
    out = tmp_path / "loso"
    args = ["fit", "arm-cmm", *map(str, paths), "--arm", "ur10", "--model", "geometry"]
    args += ["--leave-one-out", "--effects", str(tmp_path / "effects.json"), "--out", str(out)]
    assert main(args) == 0
    table = json.loads((out / "fit.json").read_text())["leave_one_out"]
    for k, ph in enumerate(phases):
        e = table[f"session{k}.csv"]
        assert not e["in_sample"] and 0.8 * 0.032 < e["mean_mm"] < 1.3 * 0.032, e
        fold = json.loads((out / f"session{k}" / "fit.json").read_text())
        own = fold["test"][f"session{k}.csv"]["session_terms_urad"]
        # the error sin(h q + ph) = cos(ph) sin(h q) + sin(ph) cos(h q), in urad
        got = np.array([own["angle_transmission2_h17.3_sin"], own["angle_transmission2_h17.3_cos"]])
        want = 1e6 * amp * np.array([np.cos(ph), np.sin(ph)])
        assert np.abs(got - want).max() < 15.0, (got, want)  # ~60 rows at 20 um: a few urad
