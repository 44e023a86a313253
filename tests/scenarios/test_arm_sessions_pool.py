"""``fit arm-cmm --leave-one-out``'s folds on a pool of spawned processes: the same figures, to
the bit, as one after another in the test's process, and a fold's bad input said as there."""

import json
import warnings

import numpy as np
import pytest

from calibench.estimators.rotations import rotvec_to_matrix
from calibench.recordings import ArmRecording
from calibench.scenarios.arm_cmm import sessions
from calibench.scenarios.arm_cmm.sessions import fold_workers, leave_one_session_out
from calibench.scenarios.report import BadInput
from calibench.sim.arm_cmm import ArmSim, ArmTruth


def _sessions(tmp_path, n=(80, 60, 70)):
    """Sessions of the twin's UR10 (``n`` postures each), each in its own tracker frame, with
    0.02 mm of tracker noise: their CSV paths."""
    sim = ArmSim("ur10", ArmTruth())
    rng = np.random.default_rng(3)
    paths = []
    for k, rows in enumerate(n):
        q = sim.random_postures(rows, rng)
        R, t = rotvec_to_matrix(rng.normal(0, 1.0, 3)), rng.uniform(-2000, 2000, 3)
        y = sim.probe_mm(q) @ R.T + t + rng.normal(0, 0.02, (rows, 3))
        paths.append(tmp_path / f"session{k}.csv")
        ArmRecording(q, y).to_csv(paths[-1])
    return paths


def test_the_pooled_folds_give_the_figures_of_the_folds_run_here(tmp_path):
    """Three sessions left out in turn, the folds once in this process and once two at a time
    on spawned processes (the third on the worker the first to finish frees): the table, each
    fold's fit.json and its residuals.csv the same to the last digit written (every fold runs
    on one BLAS thread wherever it runs)."""
    paths = _sessions(tmp_path)
    here = leave_one_session_out(paths, "ur10", "geometry", tmp_path / "here", workers=1)
    pooled = leave_one_session_out(paths, "ur10", "geometry", tmp_path / "pool", workers=2)
    assert pooled["leave_one_out"] == here["leave_one_out"]
    assert list(pooled["leave_one_out"]) == [p.name for p in paths]  # in the recordings' order
    for p in paths:
        a, b = (tmp_path / d / p.stem for d in ("here", "pool"))
        assert json.loads((a / "fit.json").read_text()) == json.loads((b / "fit.json").read_text())
        assert (a / "residuals.csv").read_bytes() == (b / "residuals.csv").read_bytes()


def test_a_folds_bad_input_is_said_as_in_this_process(tmp_path):
    """A recording whose readings are not the arm's (three joints for the UR10's six): the pool
    says the first failing fold's bad input, the line the folds run here say."""
    paths = _sessions(tmp_path, n=(40, 40))
    bad = tmp_path / "three_joints.csv"
    bad.write_text("q1_deg,q2_deg,q3_deg,x_mm,y_mm,z_mm\n" + "0,0,0,1,2,3\n" * 20)
    said = []
    for workers in (1, 2):
        with pytest.raises(BadInput) as e:
            leave_one_session_out(
                [*paths, bad], "ur10", "geometry", tmp_path / f"w{workers}", None, False, workers
            )
        said.append(str(e.value))
    assert said[0] == said[1] and "three_joints.csv" in said[0], said


def test_a_pool_is_started_only_for_recordings_of_thousands_of_rows(tmp_path, monkeypatch):
    """Small recordings run their folds here (a pool's start would cost more than it saves);
    from :data:`POOL_MIN_BYTES` on, two at a time, never more than the cores or the folds."""
    small = _sessions(tmp_path, n=(30, 30))
    assert fold_workers(small) == 1
    monkeypatch.setattr(sessions, "POOL_MIN_BYTES", 1)
    monkeypatch.setattr(sessions.os, "cpu_count", lambda: 8)
    assert fold_workers(small) == 2 and fold_workers([*small, small[0]]) == 2
    monkeypatch.setattr(sessions.os, "cpu_count", lambda: 1)
    assert fold_workers(small) == 1
    assert fold_workers([tmp_path / "missing.csv"]) == 1  # said by the fold that reads it


def test_a_workers_warnings_come_back_with_its_fold(monkeypatch):
    """A fold in a pool's worker hands back the warnings it gave, for the command to say after
    its results as it says those of the folds run in its own process."""

    def fit(*args):
        warnings.warn("a fold's warning", RuntimeWarning, stacklevel=1)
        return {"fit": {}}

    monkeypatch.setattr(sessions, "run_arm_fit", fit)
    r, said = sessions.fold_in_worker([], None, None, None, None, None, False)
    assert r == {"fit": {}}
    assert [(m, c) for m, c, _, _ in said] == [("a fold's warning", RuntimeWarning)]
