"""``calibench fit arm-cmm`` end to end on recordings the MuJoCo twin made, in docs/formats.md's CSV
format, as a user's laser-tracker series would come: a compliant UR10 with as-built errors,
each series in its own tracker frame, a few bad rows. And the bad inputs a user can give."""

import json

import numpy as np
import pytest

from calibench.estimators.rotations import rotvec_to_matrix
from calibench.recordings import ArmRecording
from calibench.scenarios.cli import main
from calibench.sim.arm_cmm import ArmSim, ArmTruth

NOISE_MM = 0.02
# the mean length of an isotropic Gaussian 3-vector of NOISE_MM per coordinate (a Maxwell
# distribution's mean, sqrt(8 / pi) sigma): a right model's mean held-out 3-D error. One length
# scatters by 0.42 of that mean (sqrt(3 - 8 / pi) / sqrt(8 / pi)), a mean of 90 rows or more by
# at most 0.045:
# the bands 0.8-1.25 below are about 5 of it, with room for a registration's few per cent
MEAN_3D_MM = NOISE_MM * np.sqrt(8 / np.pi)
STIFFNESS = (np.inf, 2.0e5, 1.5e5, np.inf, np.inf, np.inf)  # N m / rad: joints 2 and 3 give way


@pytest.fixture(scope="module")
def series(tmp_path_factory):
    """Training (600 rows), a test in the same frame (300) and one from another setup (300)."""
    d = tmp_path_factory.mktemp("ur10")
    sim = ArmSim("ur10", ArmTruth(stiffness_nm_per_rad=STIFFNESS))
    rng = np.random.default_rng(0)
    frames = {
        "same": (rotvec_to_matrix(np.array([0.01, -0.02, 2.2])), np.array([2100.0, 400.0, -250.0])),
        "new": (rotvec_to_matrix(np.array([-0.03, 0.01, -0.8])), np.array([-900.0, 1800.0, 100.0])),
    }
    paths = {}
    for name, n, frame in (("train", 600, "same"), ("test", 300, "same"), ("other", 300, "new")):
        q = sim.random_postures(n, rng)
        R, t = frames[frame]
        y = sim.probe_mm(q) @ R.T + t + rng.normal(0, NOISE_MM, (n, 3))
        q_read = q + rng.normal(0, 2e-6, q.shape)
        if name == "train":
            q_read[500:520] = q_read[
                :20
            ]  # twenty postures visited twice: the recording's repeatability
            y[500:520] = y[:20] + rng.normal(0, NOISE_MM, (20, 3))
            y[101] = y[100]  # a stale reading
            q_read[450] = q_read[200]  # a repeat of row 200's posture ...
            y[450] = y[200] + [0.0, 0.0, 1.5]  # ... measured 1.5 mm away
        paths[name] = d / f"{name}.csv"
        ArmRecording(q_read, y).to_csv(paths[name])
    return sim, paths


def _fit(paths, tmp_path, model, *extra):
    out = tmp_path / model
    code = main(
        [
            "fit",
            "arm-cmm",
            str(paths["train"]),
            "--test",
            str(paths["test"]),
            "--test-new-frame",
            str(paths["other"]),
            "--arm",
            "ur10",
            "--model",
            model,
            "--out",
            str(out),
            *extra,
        ]
    )
    return code, json.loads((out / "fit.json").read_text()) if code == 0 else None


def test_physics_recovers_the_twins_stiffness_and_carries_to_other_frames(series, tmp_path):
    sim, paths = series
    code, phys = _fit(paths, tmp_path, "physics")
    assert code == 0 and phys["converged"]
    par = {p["name"]: p for p in phys["parameters"]}
    for j in (2, 3):
        p = par[f"compliance{j}"]
        assert p["unit"] == "urad_per_nm"
        assert abs(p["estimate"] - 1e6 / STIFFNESS[j - 1]) < 3 * p["std"], p
    # where the model is right the held-out error is the tracker's noise (MEAN_3D_MM); the
    # other frame's registration on ~60 rows adds a few per cent
    for name in ("test.csv", "other.csv"):
        assert 0.8 < phys["test"][name]["mean_mm"] / MEAN_3D_MM < 1.25, phys["test"][name]
    assert "registered on" in phys["test"]["other.csv"]["frame"]
    res = _residuals(tmp_path / "physics")
    for name in ("test.csv", "other.csv"):
        tested = [
            np.linalg.norm(e) for (f, _), (role, e) in res.items() if f == name and role == "test"
        ]
        assert len(tested) == phys["test"][name]["samples"]
        assert np.mean(tested) == pytest.approx(phys["test"][name]["mean_mm"], abs=2e-6)
    registered = sum(role == "register" for (f, _), (role, _) in res.items() if f == "other.csv")
    assert registered + phys["test"]["other.csv"]["samples"] <= 300 and registered == pytest.approx(
        60, abs=2
    )
    # the training rows in the fit: measured minus modelled whitens to the injected noise
    train = np.array(
        [e for (f, _), (role, e) in res.items() if f == "train.csv" and role == "train"]
    )
    assert np.sqrt(np.mean(train**2)) == pytest.approx(NOISE_MM, rel=0.15)
    code, geo = _fit(paths, tmp_path, "geometry")
    assert code == 0
    assert not any(p["name"].startswith("compliance") for p in geo["parameters"])
    for name in ("test.csv", "other.csv"):
        assert geo["test"][name]["mean_mm"] > 1.5 * phys["test"][name]["mean_mm"]
    # the UR10's parallel axes, said
    assert any("parallel axes" in d["why"] for d in phys["dropped"])
    # the bad rows, found and named (0 = the first data row)
    flagged = {f["row"]: f["why"] for f in phys["flagged"]["train.csv"]}
    assert 101 in flagged and "stale" in flagged[101]
    assert 450 in flagged and "same posture" in flagged[450]
    assert phys["coverage"]["warnings"] == []


def test_holdout_keeps_rows_out_and_reports_them(series, tmp_path):
    _, paths = series
    out = tmp_path / "holdout"
    assert (
        main(
            [
                "fit",
                "arm-cmm",
                str(paths["train"]),
                str(paths["test"]),
                "--arm",
                "ur10",
                "--holdout",
                "0.3",
                "--out",
                str(out),
            ]
        )
        == 0
    )
    r = json.loads((out / "fit.json").read_text())
    assert r["model"] == "physics"  # the default when the arm has masses
    assert set(r["holdout"]) == {"train.csv", "test.csv"}
    assert set(r["bases"]) == {"train.csv", "test.csv"}
    for name, h in r["holdout"].items():
        assert 0.8 < h["mean_mm"] / MEAN_3D_MM < 1.25, (name, h)
        assert abs(h["samples"] - 0.3 * 300 * (2 if name == "train.csv" else 1)) <= 3
    # residuals.csv: each row once, held-out rows never in the fit, their figures those of fit.json
    res = _residuals(out)
    for name, h in r["holdout"].items():
        mine = {k: v for k, v in res.items() if k[0] == name}
        held = [np.linalg.norm(e) for (_, _), (role, e) in mine.items() if role == "holdout"]
        assert len(held) == h["samples"] and np.mean(held) == pytest.approx(h["mean_mm"], abs=2e-6)
        assert {role for role, _ in mine.values()} <= {"train", "holdout", "left_out"}
    flagged = {(name, f["row"]) for name, rows in r.get("flagged", {}).items() for f in rows}
    assert not flagged & {k for k, (role, _) in res.items() if role in ("train", "holdout")}


def test_a_held_out_row_that_disagrees_with_its_repeat_is_flagged_not_judged(series, tmp_path):
    """As in a test recording, of a held-out pair that disagrees the row farther from the model is
    named and left out of the held-out figures (a bad reading is not the model's error)."""
    from calibench.recordings import load_arm_csv

    _, paths = series
    rec = load_arm_csv(paths["train"], 6)
    held = np.random.default_rng(0).permutation(len(rec))[
        : round(0.3 * len(rec))
    ]  # fit's split (SPLIT_SEED)
    a, b = (int(i) for i in held[:2])
    q, y = rec.q_rad.copy(), rec.xyz_mm.copy()
    q[b], y[b] = q[a], y[a] + [0.0, 1.2, 0.0]  # row b: row a's posture, measured 1.2 mm away
    path = tmp_path / "pair.csv"
    ArmRecording(q, y).to_csv(path)
    out = tmp_path / "pair"
    assert (
        main(["fit", "arm-cmm", str(path), "--arm", "ur10", "--holdout", "0.3", "--out", str(out)])
        == 0
    )
    r = json.loads((out / "fit.json").read_text())
    assert b in {f["row"] for f in r["flagged"]["pair.csv"]}
    res = _residuals(out)
    assert res[("pair.csv", a)][0] == "holdout" and ("pair.csv", b) not in res
    assert r["holdout"]["pair.csv"]["max_mm"] < 0.2


def _residuals(out) -> dict:
    """residuals.csv by (file, row): (role, measured - modelled (3,)); a row twice fails."""
    lines = (out / "residuals.csv").read_text().splitlines()
    assert lines[0] == "file,row,role,ex_mm,ey_mm,ez_mm"
    res = {}
    for line in lines[1:]:
        name, row, role, *e = line.split(",")
        assert (name, int(row)) not in res
        res[name, int(row)] = (role, np.array(e, float))
    return res


def test_per_recording_harmonics_get_a_phase_in_each_training_recording(series, tmp_path):
    """``"per_recording": true`` makes one sin/cos pair per training recording; the twin has no
    such error, so each pair comes out at zero within 3 std and the held-out figures hold."""
    _, paths = series
    eff = tmp_path / "e.json"
    eff.write_text(
        json.dumps(
            {
                "scenario": "arm-cmm",
                "effects": [
                    {
                        "name": "transmission",
                        "params": {"joint": 2, "harmonics": [17], "per_recording": True},
                    }
                ],
            }
        )
    )
    out = tmp_path / "per"
    assert (
        main(
            [
                "fit",
                "arm-cmm",
                str(paths["train"]),
                str(paths["test"]),
                "--arm",
                "ur10",
                "--holdout",
                "0.3",
                "--effects",
                str(eff),
                "--out",
                str(out),
            ]
        )
        == 0
    )
    r = json.loads((out / "fit.json").read_text())
    terms = {p["name"]: p for p in r["parameters"] if p["name"].startswith("angle_")}
    assert set(terms) == {f"angle_transmission2_rec{k}_{f}" for k in (1, 2) for f in ("sin", "cos")}
    for p in terms.values():
        assert abs(p["estimate"]) < 3 * p["std"]
    for h in r["holdout"].values():
        assert 0.8 < h["mean_mm"] / MEAN_3D_MM < 1.25, h


def test_training_on_half_the_workspace_warns(series, tmp_path):
    sim, paths = series
    from calibench.recordings import load_arm_csv

    rec = load_arm_csv(paths["train"], 6)
    half = rec.subset(np.abs(rec.q_rad[:, 1] + np.pi / 2) < 0.6)  # the upper arm kept near upright
    path = tmp_path / "narrow.csv"
    half.to_csv(path)
    out = tmp_path / "narrow"
    assert (
        main(
            [
                "fit",
                "arm-cmm",
                str(path),
                "--test",
                str(paths["test"]),
                "--arm",
                "ur10",
                "--out",
                str(out),
            ]
        )
        == 0
    )
    warnings = json.loads((out / "fit.json").read_text())["coverage"]["warnings"]
    assert any("q2 spans only" in w for w in warnings), warnings
    assert any("test.csv" in w and "q2" in w for w in warnings), warnings


def test_a_same_frame_test_from_another_setup_is_said(series, tmp_path):
    """--test means the first training recording's frame; a recording from another tracker
    placement given there is metres off, which fit.json's figures show but a user reading only
    the printout's warnings could miss: it is warned about, with the option that fits it, and
    the command exits 1 (a failed check, as a fit far beyond any arm's error). The same recording
    as --test-new-frame, and the right --test, are not."""
    sim, paths = series
    out = tmp_path / "swapped"
    assert (
        main(
            [
                "fit",
                "arm-cmm",
                str(paths["train"]),
                "--test",
                str(paths["other"]),
                "--test-new-frame",
                str(paths["test"]),
                "--arm",
                "ur10",
                "--out",
                str(out),
            ]
        )
        == 1
    )
    warnings = json.loads((out / "fit.json").read_text())["coverage"]["warnings"]
    assert any(w.startswith("other.csv:") and "--test-new-frame" in w for w in warnings), warnings
    _, right = _fit(paths, tmp_path, "physics")
    assert not any("--test-new-frame" in w for w in right["coverage"]["warnings"]), right[
        "coverage"
    ]["warnings"]


def test_stated_std_in_some_recordings_only_are_said_unused(series, tmp_path):
    """One recording states its std, the other not: one weighting for both, said in a warning."""
    sim, paths = series
    from calibench.recordings import load_arm_csv

    rec = load_arm_csv(paths["train"], 6)
    stated = tmp_path / "stated.csv"
    ArmRecording(rec.q_rad, rec.xyz_mm, xyz_std_mm=np.full(rec.xyz_mm.shape, NOISE_MM)).to_csv(
        stated
    )
    out = tmp_path / "mixed"
    assert (
        main(
            ["fit", "arm-cmm", str(stated), str(paths["other"]), "--arm", "ur10", "--out", str(out)]
        )
        == 0
    )
    warnings = json.loads((out / "fit.json").read_text())["coverage"]["warnings"]
    assert any("stated.csv states a std per value, other.csv not" in w for w in warnings), warnings


def test_recordings_of_one_name_in_two_folders_are_told_apart(series, tmp_path):
    """setup1/data.csv and setup2/data.csv: both judged, each named by its folder too."""
    import shutil

    sim, paths = series
    for folder, which in (("setup1", "test"), ("setup2", "other")):
        (tmp_path / folder).mkdir()
        shutil.copy(paths[which], tmp_path / folder / "data.csv")
    out = tmp_path / "out"
    assert (
        main(
            [
                "fit",
                "arm-cmm",
                str(paths["train"]),
                "--test",
                str(tmp_path / "setup1" / "data.csv"),
                "--test-new-frame",
                str(tmp_path / "setup2" / "data.csv"),
                "--arm",
                "ur10",
                "--model",
                "geometry",
                "--out",
                str(out),
            ]
        )
        == 0
    )
    fit = json.loads((out / "fit.json").read_text())
    assert set(fit["test"]) == {"setup1/data.csv", "setup2/data.csv"}
    assert fit["test"]["setup2/data.csv"]["frame"].startswith("registered")


def _write(tmp_path, name, q_deg, xyz):
    path = tmp_path / name
    ArmRecording(np.radians(q_deg), xyz).to_csv(path)
    return path


@pytest.mark.parametrize(
    "case",
    [
        "missing_field",
        "joint_count",
        "nan",
        "few_postures",
        "one_posture_repeated",
        "radians",
        "unknown_arm",
    ],
)
def test_bad_input_is_one_line_and_exit_2(series, tmp_path, capsys, case):
    sim, paths = series
    from calibench.recordings import load_arm_csv

    rec = load_arm_csv(paths["train"], 6)
    arm = "ur10"
    csv = paths["train"]
    if case == "missing_field":
        text = (sim.arm.source and open(sim.arm.source).read()).replace("d_mm = 127.3", "", 1)
        arm = tmp_path / "arm.toml"
        arm.write_text(text)
    elif case == "joint_count":
        csv = _write(tmp_path, "five.csv", np.degrees(rec.q_rad[:, :5]), rec.xyz_mm)
    elif case == "nan":
        xyz = rec.xyz_mm.copy()
        xyz[7, 1] = np.nan
        csv = _write(tmp_path, "nan.csv", np.degrees(rec.q_rad), xyz)
    elif case == "few_postures":
        csv = _write(tmp_path, "few.csv", np.degrees(rec.q_rad[:12]), rec.xyz_mm[:12])
    elif case == "one_posture_repeated":
        csv = _write(
            tmp_path,
            "same.csv",
            np.degrees(np.repeat(rec.q_rad[:1], 300, 0)),
            np.repeat(rec.xyz_mm[:1], 300, 0) + np.random.default_rng(0).normal(0, 0.01, (300, 3)),
        )
    elif case == "radians":
        path = tmp_path / "radians.csv"
        ArmRecording(np.radians(rec.q_rad), rec.xyz_mm).to_csv(
            path
        )  # degrees columns holding radians
        csv = path
    elif case == "unknown_arm":
        arm = tmp_path / "nothing.toml"
    code = main(["fit", "arm-cmm", str(csv), "--arm", str(arm), "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err.strip()
    assert code == 2, err
    assert len(err.splitlines()) == 1 and "Traceback" not in err, err
    expect = {
        "missing_field": "d_mm",
        "joint_count": "joint",
        "nan": "nan",
        "few_postures": "postures",
        "one_posture_repeated": "distinct postures",
        "radians": "radian",
        "unknown_arm": "no such file",
    }[case]
    assert expect in err.lower(), err


def test_a_fit_far_beyond_any_arm_s_error_exits_1_with_the_reason(series, tmp_path, capsys):
    """The UR10's recording fitted as the seed's arm (the description left out): the fit is
    off by tens of millimetres, which no calibration leaves; exit 1, the reason on stderr and in
    fit.json, not only a warning among others."""
    _, paths = series
    out = tmp_path / "wrong-arm"
    # the 300 rows of the test recording: a fit this far off says so on any number of rows
    code = main(["fit", "arm-cmm", str(paths["test"]), "--arm", "arm-cmm", "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 1
    assert "fit arm-cmm failed" in err and "is the arm description right" in err
    fit = json.loads((out / "fit.json").read_text())
    assert fit["fit"]["rms_mm"] > 10.0 and fit["implausible"].startswith("the fit leaves")
