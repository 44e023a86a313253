"""Monte-Carlo studies: resume after an interruption, Dask equals the process pool, the summary's
statistics, bad input."""

import concurrent.futures as cf
import json
import os
import subprocess
import sys

import numpy as np
import pyarrow.parquet as pq
import pytest

from calibench.scenarios.cli import main
from calibench.scenarios.study.journal import JOURNAL, load_journal
from calibench.scenarios.study.montecarlo import run_study
from calibench.scenarios.study.summary import binom_ppf, chi2_ppf, summarise
from calibench.scenarios.study.trials import trial_seed


def _estimates(out):
    t = pq.read_table(out / "trials.parquet").to_pydict()
    cols = sorted(k for k in t if k.endswith(".estimate"))
    return np.array([t[c] for c in cols]).T, t["trial"]


def test_interrupted_study_keeps_finished_trials(tmp_path):
    """A study cut off after 3 of 6 trials (a torn line as the kill left it) resumes: the
    finished trials are kept as they were, only the missing ones run."""
    with cf.ThreadPoolExecutor(1) as ex:
        run_study("arm-cmm", 3, 7, "analytic", tmp_path, executor=ex, progress=False)
    first = (tmp_path / JOURNAL).read_text().splitlines()
    with open(tmp_path / JOURNAL, "a") as f:
        f.write('{"trial": 3, "se')  # the kill came mid-write
    with cf.ThreadPoolExecutor(1) as ex:
        summary = run_study("arm-cmm", 6, 7, "analytic", tmp_path, executor=ex, progress=False)
    lines = [ln for ln in (tmp_path / JOURNAL).read_text().splitlines() if ln.endswith("}")]
    assert lines[:3] == first  # untouched
    assert sorted(load_journal(tmp_path)) == list(range(6))
    assert summary["trials"] == 6 and summary["failed"] == 0
    est, trials = _estimates(tmp_path)
    assert trials == list(range(6))


def test_a_row_torn_in_its_first_bytes_is_dropped_not_called_corrupt(tmp_path):
    """A crash can cut the last row anywhere, even within its first bytes; the resume starts a
    fresh line after it. Such rows are dropped and every finished trial kept (the message used
    to call the journal corrupt and advise removing it, finished trials and all)."""
    rows = [json.dumps({"trial": i, "seed": i, "ok": True, "error": None}) for i in range(2)]
    for torn in ("{", '{"tr', '{"trial": 2, "se'):
        (tmp_path / JOURNAL).write_text("\n".join(rows) + "\n" + torn)
        assert sorted(load_journal(tmp_path)) == [0, 1]
        # resumed: a fresh line follows the torn one
        (tmp_path / JOURNAL).write_text("\n".join(rows + [torn, rows[0]]) + "\n")
        assert sorted(load_journal(tmp_path)) == [0, 1]


def test_workers_do_not_import_from_the_users_folder(tmp_path, monkeypatch):
    """A socket.py in the folder a study is started from is not run by its spawned workers (a
    worker's `python -c` used to put the folder first on its import path)."""
    marker = tmp_path / "ran"
    (tmp_path / "socket.py").write_text(
        f"open({str(marker)!r}, 'w').close()\nraise ImportError('not the standard socket')\n"
    )
    monkeypatch.chdir(tmp_path)
    args = ["montecarlo", "belt-stage", "--trials", "1", "--workers", "1"]
    assert main([*args, "--fidelity", "analytic", "--out", str(tmp_path / "o")]) == 0
    assert not marker.exists()


def test_a_scheduler_that_fails_leaves_no_study_behind(tmp_path):
    """--scheduler that cannot be used is bad input, said before any trial: the folder is left
    without a study.json (one left behind made the next run with other settings refused)."""
    out = tmp_path / "o"
    args = ["montecarlo", "belt-stage", "--trials", "2", "--fidelity", "analytic"]
    assert main([*args, "--scheduler", "notaurl", "--out", str(out)]) == 2
    assert not (out / "study.json").exists()


def test_tasks_carry_more_trials_through_dask():
    from calibench.scenarios.study.trials import DASK_CHUNK, chunk_size

    assert chunk_size(4000, "analytic") == 16
    assert chunk_size(4000, "analytic", dask_workers=2) == DASK_CHUNK
    assert chunk_size(160, "analytic", dask_workers=2) == 10  # 8 tasks or more a worker
    assert chunk_size(4000, "render", dask_workers=2) == 1


def test_dask_cluster_gives_the_pool_s_results(tmp_path):
    """The same trials, bit for bit, whatever the tasks' sizes (2 trials a task in the pool, 10
    through Dask here)."""
    distributed = pytest.importorskip("distributed")
    pool_dir, dask_dir = tmp_path / "pool", tmp_path / "dask"
    run_study("arm-cmm", 160, 11, "analytic", pool_dir, workers=2, progress=False)
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
    ) as cluster:
        run_study(
            "arm-cmm",
            160,
            11,
            "analytic",
            dask_dir,
            scheduler=cluster.scheduler_address,
            progress=False,
        )
    a, ta = _estimates(pool_dir)
    b, tb = _estimates(dask_dir)
    assert ta == tb
    np.testing.assert_array_equal(a, b)


def test_a_finished_study_needs_no_workers(tmp_path, monkeypatch):
    """Asked again with all its trials journaled, a study rewrites its outputs without starting a
    pool or reaching a cluster (the cluster of the first run may be gone)."""
    import calibench.scenarios.study.montecarlo as mc

    with cf.ThreadPoolExecutor(1) as ex:
        first = run_study("arm-cmm", 3, 5, "analytic", tmp_path, executor=ex, progress=False)

    def no_executor(*args):
        raise AssertionError("a finished study started workers")

    monkeypatch.setattr(mc, "make_executor", no_executor)
    again = run_study(
        "arm-cmm", 3, 5, "analytic", tmp_path, scheduler="tcp://127.0.0.1:9", progress=False
    )
    assert again["resumed"] == 3 and again["trials"] == first["trials"] == 3
    assert again["parameters"] == first["parameters"]


def test_a_bad_config_is_said_by_the_worker_that_checks_it(tmp_path):
    """With a local pool a worker checks the config: a bad value still comes back as one BadInput
    before any trial, nothing journaled, and the process that ran the study (a fresh one, so no
    other test's imports hide it) never imported the scenario's simulator or estimators (its
    package, which holds its registry line, alone)."""
    code = f"""
import sys
from pathlib import Path
from calibench.errors import BadInput
from calibench.scenarios.study.montecarlo import run_study
try:
    run_study("arm-cmm", 3, 0, "analytic", Path({str(tmp_path)!r}), workers=1, progress=False,
              table={{"stated_range_sigma_um": [0.0, 1.0]}})
except BadInput as e:
    print("BadInput:", e)
rooms = ("calibench.estimators", "calibench.sim", "calibench.scenarios.arm_cmm.")
print(sorted(m for m in sys.modules if m.startswith(rooms)))
"""
    out = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        timeout=120,
        env={**os.environ, "MUJOCO_GL": "egl"},
    )
    said, imported = out.stdout.strip().splitlines()
    assert said.startswith("BadInput:") and "constant term must be positive" in said, (
        out.stdout + out.stderr
    )
    assert imported == "[]", imported
    assert not (tmp_path / JOURNAL).exists() and not (tmp_path / "study.json").exists()


def test_a_config_under_which_every_trial_fails_is_bad_input(tmp_path, monkeypatch):
    """The safety net behind the config checks: a config they pass but under which no trial runs
    (here every trial's prior made to fail) is one BadInput line naming a trial's error, not an
    empty table with exit 0; the trials stay in the journal. Without a config the same failures
    are the study's result (a defect of calibench, not of the input)."""
    from calibench.errors import BadInput
    from calibench.scenarios.arm_cmm import scenario as arm_cmm

    def no_prior(config, rng):
        raise ValueError("the set-up cannot seat a cone")

    monkeypatch.setattr(arm_cmm, "prior", no_prior)
    table = {"stated_angle_sigma_urad": 6.0}
    with (
        cf.ThreadPoolExecutor(1) as ex,
        pytest.raises(
            BadInput, match="every trial failed with the config's values .*cannot seat a cone"
        ),
    ):
        run_study(
            "arm-cmm",
            3,
            0,
            "analytic",
            tmp_path / "config",
            executor=ex,
            progress=False,
            table=table,
        )
    assert len(load_journal(tmp_path / "config")) == 3
    with cf.ThreadPoolExecutor(1) as ex:
        summary = run_study(
            "arm-cmm", 3, 0, "analytic", tmp_path / "plain", executor=ex, progress=False
        )
    assert summary["failed"] == 3


def test_a_study_whose_trials_compare_nothing_is_bad_input(tmp_path, monkeypatch):
    """Trials that succeed without one parameter to compare with the truth (an arm whose every
    error its frames and tool absorb) make an empty table: one BadInput line, not exit 0."""
    from calibench.errors import BadInput
    from calibench.scenarios.arm_cmm import scenario as arm_cmm

    monkeypatch.setattr(arm_cmm, "trial_parameters", lambda config, seed: [])
    with (
        cf.ThreadPoolExecutor(1) as ex,
        pytest.raises(BadInput, match="no trial estimated a parameter"),
    ):
        run_study("arm-cmm", 3, 0, "analytic", tmp_path, executor=ex, progress=False)


def test_trials_are_reproducible_and_independent():
    assert trial_seed(0, 5) == trial_seed(0, 5)
    assert (
        len({trial_seed(0, i) for i in range(100)} | {trial_seed(1, i) for i in range(100)}) == 200
    )


def test_summary_statistics():
    rows = [
        {"trial": i, "ok": True, "p.truth": 0.0, "p.estimate": e, "p.std": 1.0, "p.unit": "mm"}
        for i, e in enumerate([0.5, -1.0, 2.5, 0.0])
    ] + [{"trial": 4, "ok": False, "error": "boom"}]
    s = summarise("x", rows, 1.0)
    (p,) = s["parameters"]
    assert s["trials"] == 5 and s["failed"] == 1
    assert p["bias"] == pytest.approx(0.5) and p["rmse"] == pytest.approx(
        np.sqrt((0.25 + 1 + 6.25) / 4)
    )
    assert p["mean_std"] == 1.0 and p["coverage_95"] == pytest.approx(0.75)


def test_coverage_counts_errors_within_1p96_std():
    """coverage_95 is the share of |error| <= 1.96 std: errors placed at 0.5, 1.8, 1.98 and 2.5
    std (std 2 mm) lie inside 1.96 for two of four, inside 2.0 for three, inside 1.645 for one;
    an exact count, no noise: each constant gives its own answer."""
    errs = np.array([0.5, -1.8, 1.98, -2.5]) * 2.0
    rows = [
        {
            "trial": i,
            "ok": True,
            "p.truth": 1.0,
            "p.estimate": 1.0 + e,
            "p.std": 2.0,
            "p.unit": "mm",
        }
        for i, e in enumerate(errs)
    ]
    (p,) = summarise("x", rows, 1.0)["parameters"]
    assert p["coverage_95"] == 0.5


@pytest.mark.parametrize("n", [1, 2, 7, 20, 60, 199, 200, 1000, 4000])
def test_quantiles_equal_scipy_stats(n):
    """The summary's chi2 and binomial quantiles, computed without scipy.stats, equal its own."""
    from scipy.stats import binom, chi2

    q = np.array([0.025, 0.5, 0.975])
    assert np.array_equal(chi2_ppf(q, n), chi2.ppf(q, n))
    for prob in (0.05, 0.5, 0.95):
        assert np.array_equal(binom_ppf(q, n, prob), binom.ppf(q, n, prob))


def test_check_summary():
    values = [0.01, 0.02, 0.03, 0.2]
    rows = [
        {"trial": i, "ok": True, "check.c_mm": v, "check.c_mm.ok": v <= 0.1}
        for i, v in enumerate(values)
    ]
    (c,) = summarise("x", rows + [{"trial": 4, "ok": False, "error": "boom"}], 1.0)["checks"]
    assert c["name"] == "c_mm" and c["n"] == 4 and c["failed_fraction"] == 0.25
    assert c["median"] == pytest.approx(0.025) and c["max"] == 0.2
    assert c["p95"] == pytest.approx(np.percentile(values, 95))
    # a value that is not a number is a failed check, not a statistic
    rows[0]["check.c_mm"], rows[0]["check.c_mm.ok"] = float("nan"), False
    (c,) = summarise("x", rows, 1.0)["checks"]
    assert c["failed_fraction"] == 0.5 and c["max"] == 0.2 and c["median"] == pytest.approx(0.03)


def test_bad_input(tmp_path, capsys):
    assert main(["montecarlo", "nope", "--trials", "3"]) == 2
    assert main(["montecarlo", "arm-cmm", "--trials", "0", "--out", str(tmp_path)]) == 2
    (tmp_path / "study.json").write_text(
        json.dumps({"scenario": "stewart", "seed": 0, "fidelity": "analytic"})
    )
    assert main(["montecarlo", "arm-cmm", "--trials", "2", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and "different study" in err


def test_cli_study_writes_the_contract_files(tmp_path):
    assert (
        main(
            [
                "montecarlo",
                "probe-scanner",
                "--trials",
                "2",
                "--workers",
                "1",
                "--out",
                str(tmp_path),
            ]
        )
        == 0
    )
    s = json.loads((tmp_path / "summary.json").read_text())
    assert s["scenario"] == "probe-scanner" and s["trials"] == 2
    assert {"name", "unit", "bias", "rmse", "mean_std", "coverage_95"} <= set(s["parameters"][0])
    assert s["checks"] and all(c["n"] == 2 for c in s["checks"])  # each trial's checks, summarised
    t = pq.read_table(tmp_path / "trials.parquet").to_pydict()
    assert {
        "trial",
        "seed",
        "ok",
        "error",
        "elapsed_s",
        "d_lsq.truth",
        "d_lsq.estimate",
        "d_lsq.std",
    } <= set(t)
    assert (tmp_path / "study.png").is_file()
    from calibench.scenarios.rrlog import entity_paths

    assert {"/study/summary", "/study/figure"} <= entity_paths(tmp_path / "study.rrd")


def test_a_study_takes_a_config_and_keeps_it(tmp_path):
    """--config overrides the scenario's defaults in every trial (here the datasheet's sigma, 1.5x
    too large: the same estimates, as the variance factor rescales only the std), is recorded in
    study.json, and a resume with another config is refused."""
    plain, scaled = tmp_path / "plain", tmp_path / "scaled"
    config = tmp_path / "c.toml"
    config.write_text(
        "[arm-cmm]\nstated_range_sigma_um = [7.5, 1.5]\nstated_angle_sigma_urad = 6.0\n"
        "stated_encoder_sigma_urad = 7.5\n"
    )
    args = ["montecarlo", "arm-cmm", "--trials", "3", "--workers", "1"]
    assert main(args + ["--out", str(plain)]) == 0
    assert main(args + ["--config", str(config), "--out", str(scaled)]) == 0
    assert (
        json.loads((scaled / "study.json").read_text())["config"]["stated_angle_sigma_urad"] == 6.0
    )
    a, _ = _estimates(plain)
    b, _ = _estimates(scaled)
    np.testing.assert_allclose(a, b, rtol=1e-6, atol=1e-9)
    assert (
        main(args + ["--out", str(scaled)]) == 2
    )  # the same folder without the config: another study
    config.write_text("[stewart]\nn_poses = 20\n")
    assert main(args + ["--config", str(config), "--out", str(tmp_path / "x")]) == 2


def test_a_scheduler_that_does_not_speak_dask_is_said_in_time(tmp_path):
    """A listener that accepts and says nothing (not a Dask scheduler) held the command for over
    a minute: now one line within the connect limit and a little more."""
    import socket
    import time

    listener = socket.socket()
    listener.bind(("127.0.0.1", 0))
    listener.listen()
    port = listener.getsockname()[1]
    t0 = time.monotonic()
    try:
        args = ["montecarlo", "belt-stage", "--trials", "2", "--fidelity", "analytic"]
        rc = main([*args, "--scheduler", f"tcp://127.0.0.1:{port}", "--out", str(tmp_path / "o")])
    finally:
        listener.close()
    assert rc == 2
    assert time.monotonic() - t0 < 30


def test_a_second_study_into_the_same_folder_is_refused_while_the_first_runs(tmp_path):
    """Two identical studies into one --out both did all the work: the second is now refused
    with one line while the first holds the folder, and runs once the first is done."""
    from calibench.scenarios.study.journal import study_lock

    out = tmp_path / "o"
    args = ["montecarlo", "belt-stage", "--trials", "2", "--fidelity", "analytic"]
    with study_lock(out):  # the first study, still running
        assert main([*args, "--workers", "1", "--out", str(out)]) == 2
    assert main([*args, "--workers", "1", "--out", str(out)]) == 0


def test_outputs_replace_a_planted_link_instead_of_following_it(tmp_path):
    """An output written in place followed a symbolic link planted at its name out of --out;
    now each output is written beside it and renamed over the name (the link itself). In a
    folder no command marked, the link is a user's file by an output's name: refused."""
    out, outside = tmp_path / "o", tmp_path / "outside.json"
    outside.write_text("untouched")
    out.mkdir()
    (out / "summary.json").symlink_to(outside)
    args = ["montecarlo", "belt-stage", "--fidelity", "analytic", "--workers", "1"]
    assert main([*args, "--trials", "1", "--out", str(out)]) == 2
    (out / "summary.json").unlink()
    assert main([*args, "--trials", "1", "--out", str(out)]) == 0  # the folder is the study's
    (out / "summary.json").unlink()
    (out / "summary.json").symlink_to(outside)
    assert main([*args, "--trials", "2", "--out", str(out)]) == 0
    assert outside.read_text() == "untouched"
    assert not (out / "summary.json").is_symlink()


def test_a_full_disk_is_one_line_and_keeps_the_trials(tmp_path, monkeypatch, capsys):
    """A full disk is the user's to fix: one line (it printed an internal error and an empty
    error.log), the journal of finished trials kept for the rerun."""
    import errno

    from calibench.scenarios.study import montecarlo

    def full(*args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device", str(tmp_path / "o" / "x.parquet"))

    monkeypatch.setattr(montecarlo, "write_outputs", full)
    # the error's one line: a study longer than 10 s (a busy machine) would add progress lines
    monkeypatch.setenv("CALIBENCH_PROGRESS", "off")
    args = ["montecarlo", "belt-stage", "--trials", "2", "--fidelity", "analytic"]
    assert main([*args, "--workers", "1", "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "the disk is full writing" in err[0], err
    assert sorted(load_journal(tmp_path / "o")) == [0, 1]


def _self_signed(tmp_path):
    """A self-signed certificate and its key (PEM), by the openssl command, which serves as the
    cluster's authority, the scheduler's, the workers' and the client's certificate."""
    import shutil

    if shutil.which("openssl") is None:
        pytest.skip("the openssl command makes the test's certificates")
    cert, key = tmp_path / "cert.pem", tmp_path / "key.pem"
    subprocess.run(
        ["openssl", "req", "-x509", "-newkey", "rsa:2048", "-nodes", "-days", "1"]
        + ["-subj", "/CN=localhost", "-keyout", str(key), "-out", str(cert)],
        check=True,
        capture_output=True,
    )
    return cert, key


def test_a_tls_cluster_gives_the_pool_s_results(tmp_path):
    """--scheduler tls:// with the certificate files on the command line, against a local
    cluster that requires encryption (self-signed certificates): the same trials as the local
    pool, bit for bit; without the files, one line that says which are missing."""
    distributed = pytest.importorskip("distributed")
    from distributed.security import Security

    cert, key = _self_signed(tmp_path)
    files = {
        f"tls_{who}_{k}": str(v)
        for who in ("scheduler", "worker", "client")
        for k, v in (("cert", cert), ("key", key))
    }
    security = Security(tls_ca_file=str(cert), require_encryption=True, **files)
    pool_dir = tmp_path / "pool"
    run_study("arm-cmm", 4, 11, "analytic", pool_dir, workers=2, progress=False)
    args = ["montecarlo", "arm-cmm", "--trials", "4", "--seed", "11", "--fidelity", "analytic"]
    with distributed.LocalCluster(
        n_workers=2,
        threads_per_worker=1,
        processes=True,
        dashboard_address=None,
        protocol="tls",
        security=security,
    ) as cluster:
        address = cluster.scheduler_address
        assert address.startswith("tls://")
        assert main([*args, "--scheduler", address, "--out", str(tmp_path / "none")]) == 2
        tls = ["--tls-ca-file", str(cert), "--tls-cert", str(cert), "--tls-key", str(key)]
        assert main([*args, "--scheduler", address, *tls, "--out", str(tmp_path / "tls")]) == 0
    a, ta = _estimates(pool_dir)
    b, tb = _estimates(tmp_path / "tls")
    assert ta == tb
    np.testing.assert_array_equal(a, b)
