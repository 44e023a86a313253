"""Leave-one-session-out on the arm: a left-out session's frame and own terms are fitted on the
fifth of its rows that register it, never on the rows that score it (issue 63: fitted on the
scored rows, every one of the 240, the figure moved 3 % and no test saw it)."""

import csv
import json

import numpy as np

from calibench.estimators.rotations import rotvec_to_matrix
from calibench.recordings import ArmRecording, load_arm_csv
from calibench.scenarios.arm_cmm.sessions import leave_one_session_out
from calibench.scenarios.provenance import rows_in
from calibench.sim.arm_cmm import ArmSim, ArmTruth

NOISE_MM, AMP_RAD, HARMONIC = 0.02, 300e-6, 17.3


def _sessions(folder, phases=(0.4, 2.5), n=200):
    """Sessions of the twin's UR10 (MuJoCo), each in its own tracker frame, whose joint 2 is off
    by :data:`AMP_RAD` at :data:`HARMONIC` cycles per turn with its phase set at each power-up;
    and an effects file that gives fit that harmonic per session (chosen on none of their rows).
    Returns the sessions' CSV paths and the effects file's."""
    sim = ArmSim("ur10", ArmTruth())
    rng = np.random.default_rng(8)
    paths = []
    for k, ph in enumerate(phases):
        q = sim.random_postures(n, rng)
        link = q.copy()
        link[:, 1] -= AMP_RAD * np.sin(HARMONIC * q[:, 1] + ph)
        R, t = rotvec_to_matrix(rng.normal(0, 1.0, 3)), rng.uniform(-2000, 2000, 3)
        y = sim.point_mm(link) @ R.T + t + rng.normal(0, NOISE_MM, (n, 3))
        paths.append(folder / f"session{k}.csv")
        ArmRecording(q, y).to_csv(paths[-1])
    harmonic = {"joint": 2, "harmonics": [HARMONIC], "per_recording": True}
    effects = {
        "scenario": "arm-cmm",
        "effects": [{"name": "transmission", "params": harmonic}],
        "provenance": {
            "recordings": [{"file": "bench.csv", "sha256": "0" * 64, "rows": {"chose": [[0, 99]]}}]
        },
    }
    (folder / "effects.json").write_text(json.dumps(effects))
    return paths, folder / "effects.json"


def _rows_of(fold_dir, name: str) -> dict[str, dict[int, np.ndarray]]:
    """A fold's residuals.csv rows of recording ``name``: {role: {row: (3,) measured minus
    modelled, mm}}."""
    out: dict[str, dict[int, np.ndarray]] = {}
    with open(fold_dir / "residuals.csv") as f:
        for r in csv.DictReader(f):
            if r["file"] == name:
                e = np.array([float(r[k]) for k in ("ex_mm", "ey_mm", "ez_mm")])
                out.setdefault(r["role"], {})[int(r["row"])] = e
    return out


def test_a_left_out_sessions_fitted_rows_are_never_its_scored_rows(tmp_path):
    """Two sessions, each left out in turn: its frame and its own harmonic's phase are fitted on
    the rows fit.json and residuals.csv say registered it (40 of 200), scored on the others
    (160), and the two never share a row. What the fit touched is then checked, not only what
    it says: the left-out session's scored rows moved by 0.3 mm each (the fold's calibration, on
    the other session alone, unchanged) leave its frame, its terms and its registration rows'
    residuals as they were, to the 1 nm residuals.csv writes, and the scored errors move by
    exactly what was added. A frame fitted on the scored rows would follow them by about
    0.3 mm / sqrt(160 rows), 24 um."""
    paths, effects = _sessions(tmp_path)
    names = [p.name for p in paths]
    loso = leave_one_session_out(paths, "ur10", "geometry", tmp_path / "loso", effects)
    for name, stem in zip(names, (p.stem for p in paths)):
        fold = json.loads((tmp_path / "loso" / stem / "fit.json").read_text())
        (mine,) = [e["rows"] for e in fold["provenance"] if e["file"] == name]
        fitted, scored = rows_in(mine["fitted"]), rows_in(mine["scored"])
        assert len(fitted) == 40 and len(scored) == 160, (name, mine)
        assert not np.intersect1d(fitted, scored).size, (name, np.intersect1d(fitted, scored))
        assert loso["leave_one_out"][name]["samples"] == len(scored)
        assert not loso["leave_one_out"][name]["in_sample"]
        rows = _rows_of(tmp_path / "loso" / stem, name)
        assert set(rows) == {"register", "test"}, set(rows)
        assert sorted(rows["register"]) == fitted.tolist()
        assert sorted(rows["test"]) == scored.tolist()

    # session0's scored rows moved; session1 untouched (it trains fold 0 alone)
    clean = _rows_of(tmp_path / "loso" / "session0", names[0])
    scored = np.array(sorted(clean["test"]))
    rec = load_arm_csv(paths[0], 6)
    moved_by = np.random.default_rng(1).normal(0, 0.3, (len(scored), 3))
    xyz = rec.xyz_mm.copy()
    xyz[scored] += moved_by
    (tmp_path / "moved").mkdir()
    ArmRecording(rec.q_rad, xyz).to_csv(tmp_path / "moved" / names[0])
    moved_paths = [tmp_path / "moved" / names[0], paths[1]]
    leave_one_session_out(moved_paths, "ur10", "geometry", tmp_path / "moved" / "loso", effects)
    moved = _rows_of(tmp_path / "moved" / "loso" / "session0", names[0])
    # what was added, as the CSV holds it (its digits round the draw)
    added = (load_arm_csv(moved_paths[0], 6).xyz_mm - rec.xyz_mm)[scored]
    assert np.abs(added - moved_by).max() < 1e-4  # the rows did move, by the draw
    assert sorted(moved["register"]) == sorted(clean["register"])
    assert sorted(moved["test"]) == scored.tolist()
    for r, e in clean["register"].items():
        np.testing.assert_allclose(moved["register"][r], e, rtol=0, atol=2e-6, err_msg=f"row {r}")
    now = np.array([moved["test"][r] for r in scored])
    was = np.array([clean["test"][r] for r in scored])
    np.testing.assert_allclose(now - was, added, rtol=0, atol=2e-6)
    terms = [
        json.loads((d / "session0" / "fit.json").read_text())["test"][names[0]]
        for d in (tmp_path / "loso", tmp_path / "moved" / "loso")
    ]
    for k, v in terms[0]["session_terms_urad"].items():
        assert abs(terms[1]["session_terms_urad"][k] - v) < 1e-6, (k, terms)
