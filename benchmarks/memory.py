"""Peak memory of each verb on its largest accepted input: ``python benchmarks/memory.py [DATA]``
prints the README's table (``python -m docs.figures memory`` writes it into the README).

Each command runs as its own process on an input at the verb's limit (README, "Limits"), built
here in a scratch folder; its peak resident memory is the kernel's (``wait4``'s ``ru_maxrss``,
the largest of the process and the children it waited for). The inputs are well-formed
recordings of the instruments' twins or, for ``camera``, OpenCV's sample photos scaled up to the
megapixel limit: what is measured is the verb's own memory, whatever it concludes.

DATA: the real data's folder (default the project's data/), for the photos.
"""

from __future__ import annotations

import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

PHOTOS = 3  # photos at the limit given to `camera`


def peak(argv: list[str], cwd: Path) -> tuple[float, float, int]:
    """(peak resident memory in MB, seconds, exit status) of ``calibench argv``."""
    env = dict(os.environ, MUJOCO_GL=os.environ.get("MUJOCO_GL", "egl"))
    t = time.perf_counter()
    proc = subprocess.Popen(
        [sys.executable, "-m", "calibench.scenarios.cli", *argv],
        cwd=cwd,
        env=env,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
    )
    _, status, usage = os.wait4(proc.pid, 0)
    seconds = time.perf_counter() - t
    proc.returncode = os.waitstatus_to_exitcode(status)
    err = proc.stderr.read().decode() if proc.stderr else ""
    if proc.returncode not in (0, 1):
        raise RuntimeError(f"calibench {' '.join(argv)}: exit {proc.returncode}: {err[-400:]}")
    return usage.ru_maxrss / 1024, seconds, proc.returncode


def stage_csv(path: Path, n: int) -> Path:
    """A belt stage's recording of ``n`` rows: a grid over 300 x 200 mm, a scale and squareness
    error and 5 um of noise (a well-formed recording, not a calibration truth)."""
    rng = np.random.default_rng(0)
    cmd = rng.uniform([0, 0], [300, 200], (n, 2))
    meas = cmd * (1 + 2e-4) + cmd[:, ::-1] * [1e-4, 0] + rng.normal(0, 0.005, (n, 2))
    np.savetxt(
        path,
        np.hstack([cmd, meas]),
        fmt="%.4f",
        delimiter=",",
        header="x_cmd_mm,y_cmd_mm,x_meas_mm,y_meas_mm",
        comments="",
    )
    return path


def arm_csv(path: Path, n: int) -> Path:
    """A UR10's recording of ``n`` postures from its MuJoCo twin with compliant joints, seen by
    a tracker 1.5 m away with 20 um of noise (as benchmarks/arm_cmm.py)."""
    from calibench.sim.arm_cmm import ArmSim, ArmTruth

    description = ArmSim("ur10").arm
    sim = ArmSim(description, ArmTruth(stiffness_nm_per_rad=(3e5, 2e5, 3e5, 6e4, 6e4, 6e4)))
    rng = np.random.default_rng(1)
    q = sim.random_postures(n, rng)
    R = np.array([[0, -1, 0], [1, 0, 0], [0, 0, 1.0]])
    y = sim.probe_mm(q) @ R.T + [1500.0, -300.0, 200.0] + rng.normal(0, 0.02, (n, 3))
    head = ",".join([f"q{j + 1}_deg" for j in range(6)] + ["x_mm", "y_mm", "z_mm"])
    np.savetxt(
        path, np.hstack([np.degrees(q), y]), fmt="%.6f", delimiter=",", header=head, comments=""
    )
    return path


def iso230_csv(path: Path, n: int) -> Path:
    """``n`` readings of a bidirectional run: n / 10 targets, 5 runs each way."""
    targets = np.repeat(np.linspace(0, 1000, n // 10), 10)
    run = np.tile(np.repeat([1, 2, 3, 4, 5], 2), n // 10)
    direction = np.tile([1, -1], n // 2)
    dev = 3 * np.sin(targets / 50) + direction + np.random.default_rng(2).normal(0, 0.5, n)
    np.savetxt(
        path,
        np.column_stack([targets, run, direction, dev]),
        fmt=["%.4f", "%d", "%d", "%.3f"],
        delimiter=",",
        header="target_mm,run,direction,deviation_um",
        comments="",
    )
    return path


def photos(folder: Path, data: Path, megapixels: float) -> list[Path]:
    """OpenCV's first sample photos scaled up to ``megapixels`` (4:3), as JPEGs."""
    import cv2

    w = int(np.sqrt(megapixels * 1e6 * 4 / 3)) // 8 * 8
    h = w * 3 // 4
    out = []
    for k, src in enumerate(sorted((data / "opencv_left").glob("left*.jpg"))[:PHOTOS]):
        img = cv2.resize(cv2.imread(str(src)), (w, h), interpolation=cv2.INTER_CUBIC)
        out.append(folder / f"photo{k}.jpg")
        cv2.imwrite(str(out[-1]), img, [cv2.IMWRITE_JPEG_QUALITY, 90])
    return out


def cases(d: Path, data: Path) -> list[tuple[str, str, list[str]]]:
    """(verb, its input at the limit, argv) for each verb that reads a file."""
    from calibench.recordings.axis_run import MAX_ROWS as ISO_ROWS
    from calibench.scenarios.arm_cmm.fit import MAX_ROWS as ARM_ROWS
    from calibench.scenarios.camera import MAX_PIXELS
    from calibench.scenarios.discover.engine import MAX_ROWS as DISCOVER_ROWS
    from calibench.scenarios.stage_fit import MAX_ROWS as STAGE_ROWS

    mp = MAX_PIXELS / 1e6
    pics = photos(d, data, mp)
    return [
        (
            "camera",
            f"{len(pics)} photos of {mp:.0f} megapixels",
            ["camera", *map(str, pics), "--cols", "9", "--rows", "6", "--square-mm", "25"],
        ),
        (
            "fit belt-stage",
            f"{STAGE_ROWS:,} rows",
            ["fit", "belt-stage", str(stage_csv(d / "stage.csv", STAGE_ROWS))],
        ),
        (
            "fit arm-cmm",
            f"{ARM_ROWS:,} postures of a UR10",
            ["fit", "arm-cmm", str(arm_csv(d / "arm.csv", ARM_ROWS)), "--arm", "ur10"],
        ),
        (
            "discover belt-stage",
            f"{DISCOVER_ROWS:,} rows",
            ["discover", "belt-stage", str(stage_csv(d / "stage_d.csv", DISCOVER_ROWS))],
        ),
        (
            "iso230",
            f"{ISO_ROWS:,} readings",
            ["iso230", str(iso230_csv(d / "iso.csv", ISO_ROWS))],
        ),
    ]


def table(data: Path) -> str:
    """The README's table (markdown) and the machine it was measured on."""
    from belt_stage import cpu_model

    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        rows = []
        for verb, what, argv in cases(d, data):
            mb, s, status = peak([*argv, "--out", str(d / "out" / verb.replace(" ", "-"))], d)
            rows.append(f"| `{verb}` | {what} | {mb:,.0f} MB | {s:.0f} s |")
    return "\n".join(
        [
            f"Measured on {cpu_model()}, {os.cpu_count()} cores, by `python benchmarks/memory.py`.",
            "",
            "| verb | its largest accepted input | peak memory | time |",
            "|---|---|---|---|",
            *rows,
        ]
    )


def main() -> None:
    data = Path(sys.argv[1]) if len(sys.argv) > 1 else HERE.parent / "data"
    print(table(data))


if __name__ == "__main__":
    main()
