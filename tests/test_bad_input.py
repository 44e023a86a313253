"""The bad-input corpus: every verb and the config, fed what users actually feed them.

Each case asserts docs/formats.md's answer to bad input: exit status 2, one line on stderr that
names the problem (the fragment), no traceback, and no output file holding a wrong result. A few
inputs are odd but legitimate (a UTF-8 byte-order mark, CRLF line ends): those must exit 0.
"""

from __future__ import annotations

import dataclasses
import json
import shutil
from pathlib import Path

import pytest

from calibench.scenarios.cli import main
from tests.bad_input import (
    acceptance,
    arm_probe,
    arm_tree,
    camera,
    cli,
    config,
    discover,
    fit_arm,
    fit_stage,
    iso230,
    montecarlo,
    uncertainty,
)

RESULTS = (
    "report.json",
    "fit.json",
    "discovery.json",
    "summary.json",
    "intrinsics.json",
    "iso230.json",
    "acceptance.json",
    "uncertainty.json",
)

# --- the corpus: one module per verb under tests/bad_input/ ---------------------------------
# (id, files to write {name: text or bytes or callable(path)}, argv with {d} for the case folder,
#  expected exit status, a fragment the message must contain)
CASES = (
    cli.CASES
    + config.CASES
    + fit_stage.CASES
    + fit_arm.CASES
    + arm_tree.CASES
    + arm_probe.CASES
    + discover.CASES
    + montecarlo.CASES
    + camera.CASES
    + iso230.CASES
    + acceptance.CASES
    + uncertainty.CASES
)

# the photo cases that need the shared data (real boards): (id, builder(shared, d) -> argv,
# fragment)
PHOTO_CASES = [
    ("camera-same-photo-thrice", "the same view as copy0.jpg"),
    ("camera-first-photo-other-size", None),  # legitimately odd: the twelve others calibrate
]


def _materialise(d: Path, files: dict) -> None:
    for name, content in files.items():
        p = d / name
        p.parent.mkdir(parents=True, exist_ok=True)
        if callable(content):
            content(p)
        elif isinstance(content, bytes):
            p.write_bytes(content)
        else:
            p.write_text(content)


def _check(capsys, d: Path, argv: list[str], status: int, fragment: str) -> None:
    argv = [a.replace("{d}", str(d)) for a in argv]
    before = {p for p in d.rglob("*")}
    with pytest.MonkeyPatch.context() as mp:
        # the one line of bad input: a command that finds it after 10 s says progress lines
        # first off a terminal (tests/scenarios/test_progress.py tests those)
        mp.setenv("CALIBENCH_PROGRESS", "off")
        got = main(argv)
    err = capsys.readouterr().err.strip()
    assert "Traceback" not in err, err
    if status == 0:
        assert got == 0, err
        return
    assert got == status, f"exit {got}: {err}"
    lines = err.splitlines()
    assert len(lines) == 1, err
    assert fragment in err, err
    new = {p for p in d.rglob("*")} - before
    assert not [p for p in new if p.name in RESULTS], new


def test_the_corpus_is_large_and_distinct():
    ids = [c[0] for c in CASES] + [c[0] for c in PHOTO_CASES]
    assert len(ids) == len(set(ids))
    assert len(ids) >= 100


@pytest.mark.parametrize("case", CASES, ids=[c[0] for c in CASES])
def test_bad_input(case, tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)  # a default --out lands in the case's folder
    _, files, argv, status, fragment = case
    _materialise(tmp_path, files)
    _check(capsys, tmp_path, argv, status, fragment)


@pytest.mark.parametrize("case", PHOTO_CASES, ids=[c[0] for c in PHOTO_CASES])
def test_bad_photos(case, real_data, tmp_path, capsys, monkeypatch):
    import cv2

    monkeypatch.chdir(tmp_path)
    name, fragment = case
    left = sorted((real_data / "opencv_left").glob("*.jpg"))
    if name == "camera-same-photo-thrice":
        paths = []
        for k in range(3):
            paths.append(tmp_path / f"copy{k}.jpg")
            shutil.copy(left[0], paths[-1])
    else:  # the first photo a different size, the other twelve fine
        img = cv2.imread(str(left[0]))
        cv2.imwrite(str(tmp_path / "first.png"), cv2.resize(img, (320, 240)))
        paths = [tmp_path / "first.png"] + left[1:]
    argv = (
        ["camera"]
        + [str(p) for p in paths]
        + ["--cols", "9", "--rows", "6", "--square-mm", "25", "--out", str(tmp_path / "o")]
    )
    _check(capsys, tmp_path, argv, 0 if fragment is None else 2, fragment or "")
    if fragment is None:
        r = json.loads((tmp_path / "o" / "intrinsics.json").read_text())
        assert len(r["used"]) == 12 and "differs" in r["rejected"]["first.png"]


def test_every_default_config_passes_its_own_validation():
    """The ranges the config checks (counts, scatters, sizes) must admit every scenario's
    defaults."""
    from calibench.scenarios.config import override
    from calibench.scenarios.registry import SCENARIOS

    def table(o):
        out = {}
        for f in dataclasses.fields(o):
            v = getattr(o, f.name)
            out[f.name] = (
                table(v)
                if dataclasses.is_dataclass(v)
                else v.tolist()
                if hasattr(v, "tolist")
                else list(v)
                if isinstance(v, tuple)
                else v
            )
        return out

    for name, s in SCENARIOS.items():
        c = s.config()
        assert table(override(c, table(c), name)) == table(c)


@pytest.mark.parametrize(
    "verb, journal_name",
    [
        (["montecarlo", "belt-stage", "--trials", "400"], "trials.jsonl"),
        (["uncertainty", "belt-stage"], "uncertainty_trials.jsonl"),
    ],
    ids=["montecarlo", "uncertainty"],
)
def test_ctrl_c_during_a_study_is_one_line_and_keeps_the_trials(tmp_path, verb, journal_name):
    """SIGINT to the whole process group (what a terminal's Ctrl-C does): the parent says one
    line and exits 130, the workers print nothing, the journal keeps what finished (a Monte Carlo
    study's and an uncertainty study's alike)."""
    import os
    import signal
    import subprocess
    import sys
    import time

    out = tmp_path / "study"
    env = {**os.environ, "MUJOCO_GL": "egl"}
    proc = subprocess.Popen(
        [sys.executable, "-m", "calibench.scenarios.cli", *verb, "--workers", "1"]
        + ["--out", str(out)],
        stderr=subprocess.PIPE,
        stdout=subprocess.DEVNULL,
        env=env,
        start_new_session=True,
        text=True,
    )
    journal = out / journal_name
    deadline = time.time() + 120
    while time.time() < deadline and not (journal.exists() and journal.stat().st_size > 0):
        time.sleep(0.2)
    os.killpg(proc.pid, signal.SIGINT)
    try:
        _, err = proc.communicate(timeout=60)
    finally:  # never leave a study running behind the tests
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    assert proc.returncode == 130, err
    assert err.strip().splitlines() == [
        "calibench: interrupted; finished trials are kept, rerun the same command to resume"
    ], err
    rows = [json.loads(line) for line in journal.read_text().splitlines() if line.strip()]
    assert rows and all(r.get("ok", True) and r.get("values", [0]) for r in rows)


def test_a_float_tiff_is_one_line_without_opencvs_warnings(tmp_path, capfd):
    """OpenCV's TIFF decoder printed its own warnings (a dozen lines, at the file descriptor)
    beside calibench's one line; they are silenced while a photo is decoded."""
    import cv2
    import numpy as np

    from calibench.scenarios.cli import main

    cv2.imwrite(str(tmp_path / "f.tiff"), np.random.default_rng(0).random((48, 64)).astype("f4"))
    args = ["camera", str(tmp_path / "f.tiff"), "--cols", "9", "--rows", "6", "--square-mm", "25"]
    assert main([*args, "--out", str(tmp_path / "o")]) == 2
    err = capfd.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "f.tiff: not a readable image" in err[0], err
