"""Issue 62: nothing lost on a full disk, nothing written through a link. Every output is written
whole or not at all (calibench.writing), a claim's release restores the former results where the
command wrote none whole, and a file-size limit, a full disk, a killed write or a torn result never
leaves a torn file in place of a result."""

from __future__ import annotations

import errno
import json
import os
import resource
import subprocess
import sys
from pathlib import Path

import pytest

from calibench.scenarios.cli import main
from calibench.scenarios.cli.folders import MARK
from calibench.writing import PREFIX, is_temporary, replaced, write_text

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "belt_stage_paper.csv"
CLI = [sys.executable, "-m", "calibench.scenarios.cli"]


def _iso_run(path: Path) -> Path:
    """A valid ISO 230-2 run: 5 targets, 5 runs each way."""
    rows = ["target_mm,run,direction,deviation_um"]
    rows += [
        f"{t},{r},{d},{0.1 * r + 0.3 * d + 0.01 * t:.3f}"
        for t in range(0, 500, 100)
        for r in range(1, 6)
        for d in (1, -1)
    ]
    path.write_text("\n".join(rows) + "\n")
    return path


def _limited(argv: list[str], limit: int, cwd: Path) -> subprocess.CompletedProcess:
    """The command run with a file-size limit of ``limit`` bytes (``ulimit -f``)."""

    def cap() -> None:
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))

    env = {**os.environ, "MUJOCO_GL": "egl", "CALIBENCH_PROGRESS": "off"}
    return subprocess.run(
        [*CLI, *argv], capture_output=True, text=True, cwd=cwd, env=env, preexec_fn=cap
    )


def _leftovers(folder: Path) -> list[str]:
    return [p.name for p in folder.iterdir() if is_temporary(p.name)]


def test_force_on_a_size_limit_keeps_the_former_results(tmp_path):
    """Issue 62 item 1: `fit`, then `iso230 --force` under `ulimit -f 2`: exit 2 in one line (it
    was 3), fit.json back whole, no iso230.json of 2,048 bytes of invalid JSON."""
    out = tmp_path / "d"
    assert main(["fit", "belt-stage", str(EXAMPLE), "--out", str(out)]) == 0
    before = (out / "fit.json").read_bytes()
    run = _iso_run(tmp_path / "R.csv")
    got = _limited(["iso230", str(run), "--out", str(out), "--force"], 2048, tmp_path)
    assert got.returncode == 2, got.stderr
    assert len(got.stderr.strip().splitlines()) == 1 and "file-size limit" in got.stderr
    assert (out / "fit.json").read_bytes() == before
    assert not (out / "iso230.json").exists() and not (out / "iso230.png").exists()
    assert json.loads((out / MARK).read_text())["command"] == "fit"
    assert not _leftovers(out) and not (out / "error.log").exists()


def test_a_size_limit_without_force_leaves_no_torn_fit(tmp_path):
    got = _limited(["fit", "belt-stage", str(EXAMPLE), "--out", "d"], 1024, tmp_path)
    assert got.returncode == 2, got.stderr
    assert not (tmp_path / "d").exists()  # made for the command, left as it was found


def test_a_size_limit_on_run_rrd_is_one_line_without_rerun_s_log(tmp_path):
    """Issue 62 item 7: rerun's file writer stopped by a full disk or a size limit raised a
    RuntimeError (exit 3, an empty error.log) after rerun's coloured log lines."""
    got = _limited(["run", "stewart", "--out", "o"], 200_000, tmp_path)
    assert got.returncode == 2, got.stderr
    assert "\x1b[" not in got.stderr and "Traceback" not in got.stderr
    assert "file-size limit writing" in got.stderr and "run.rrd" in got.stderr.splitlines()[-1]
    assert not (tmp_path / "o").exists()


def test_a_full_disk_mid_write_leaves_the_former_file_and_no_temporary(tmp_path):
    path = tmp_path / "fit.json"
    path.write_text('{"old": 1}\n')
    with pytest.raises(OSError) as e:
        with replaced(path) as tmp:
            tmp.write_text('{"new": ')
            raise OSError(errno.ENOSPC, "No space left on device")
    assert e.value.errno == errno.ENOSPC and e.value.filename == str(path)
    assert path.read_text() == '{"old": 1}\n'
    assert list(tmp_path.iterdir()) == [path]


def test_a_torn_result_is_no_result_and_the_former_results_come_back(tmp_path, monkeypatch):
    """A writer that tears its result in place (a full disk midway) wrote no result: the release
    removes the torn file and puts back what --force set aside."""
    from calibench.scenarios import stage_fit

    out = tmp_path / "d"
    assert main(["iso230", str(_iso_run(tmp_path / "R.csv")), "--out", str(out)]) == 0
    before = (out / "iso230.json").read_bytes()

    def torn(path, text):
        Path(path).write_text(text[:50])
        raise OSError(errno.ENOSPC, "No space left on device", str(path))

    monkeypatch.setattr(stage_fit, "write_text", torn)
    assert main(["fit", "belt-stage", str(EXAMPLE), "--out", str(out), "--force"]) == 2
    assert not (out / "fit.json").exists()
    assert (out / "iso230.json").read_bytes() == before
    assert json.loads((out / MARK).read_text())["command"] == "iso230"


def test_a_killed_write_s_temporary_file_is_removed_by_the_next_command(tmp_path):
    out = tmp_path / "d"
    assert main(["fit", "belt-stage", str(EXAMPLE), "--out", str(out)]) == 0
    (out / f"{PREFIX}abc.fit.json").write_text('{"torn')
    (out / f"{PREFIX}def.d").mkdir()
    assert main(["fit", "belt-stage", str(EXAMPLE), "--out", str(out)]) == 0
    assert not _leftovers(out)


def test_an_output_keeps_the_folder_s_usual_mode(tmp_path):
    write_text(tmp_path / "a.json", "{}")
    mask = os.umask(0)
    os.umask(mask)
    assert (tmp_path / "a.json").stat().st_mode & 0o777 == 0o666 & ~mask


def test_sigkill_at_any_moment_of_a_forced_fit_leaves_old_or_new_results_whole(tmp_path):
    """A forced fit killed outright at several moments (the mark set aside, the results moved, the
    fit written): the next command in the folder finds the former iso230 results and their mark,
    or the whole new fit with its own; never a torn file, never a temporary one."""
    import signal
    import time

    run = _iso_run(tmp_path / "R.csv")
    env = {**os.environ, "MUJOCO_GL": "egl", "CALIBENCH_PROGRESS": "off"}
    seen = set()
    for k, delay in enumerate((0.5, 0.9, 1.2, 1.5, 1.8, 2.4)):
        out = tmp_path / f"d{k}"
        assert main(["iso230", str(run), "--out", str(out)]) == 0
        iso = (out / "iso230.json").read_bytes()
        argv = [*CLI, "fit", "belt-stage", str(EXAMPLE), "--out", str(out), "--force"]
        proc = subprocess.Popen(argv, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
        time.sleep(delay)
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        # the next command settles what the killed one left, as its release would have
        assert main(["iso230", str(run), "--out", str(out)]) in (0, 2)
        held = json.loads((out / MARK).read_text())["command"]
        if held == "iso230":
            assert (out / "iso230.json").read_bytes() == iso and not (out / "fit.json").exists()
        else:
            assert json.loads((out / "fit.json").read_text())["scenario"] == "belt-stage"
        assert not _leftovers(out) and not (out / ".calibench-claim").exists()
        seen.add(held)
    assert "iso230" in seen, seen  # at least one kill landed before the fit was written


def test_a_rerun_cut_off_by_the_disk_keeps_every_former_output(tmp_path):
    """The same command again (no --force) on a disk that fills at run.rrd: the recording and
    figure it had already replaced come back with the former report, bit for bit: never a
    report of one seed beside another seed's recording."""
    out = tmp_path / "o"
    assert main(["run", "stewart", "--out", str(out)]) == 0
    before = {p.name: p.read_bytes() for p in out.iterdir()}
    got = _limited(["run", "stewart", "--seed", "1", "--out", str(out)], 200_000, tmp_path)
    assert got.returncode == 2, got.stderr
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before


def test_camera_replaces_a_link_at_intrinsics_json_never_writes_through_it(real_data, tmp_path):
    """Issue 62, item 2: a link at an output's name is replaced by the rename, its target kept."""
    images = sorted((real_data / "opencv_left").glob("*.jpg"))
    out, precious = tmp_path / "o", tmp_path / "p"
    argv = ["camera", *map(str, images), "--cols", "9", "--rows", "6", "--square-mm", "25"]
    assert main([*argv, "--out", str(out)]) == 0
    precious.write_text("PRECIOUS")
    (out / "intrinsics.json").unlink()
    (out / "intrinsics.json").symlink_to(precious)
    assert main([*argv, "--out", str(out), "--force"]) == 0
    assert precious.read_text() == "PRECIOUS"
    assert not (out / "intrinsics.json").is_symlink()
    assert "K" in json.loads((out / "intrinsics.json").read_text())
