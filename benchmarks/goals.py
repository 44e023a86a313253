"""Issue 39's goals, each measured beside its peer in the same run (``results.py`` prints them).

- ``calibench camera`` as a whole command (a fresh Python: imports, photos, intrinsics.json,
  camera.png) against OpenCV's classic pipeline as a whole script, alternated;
- a study's fixed cost: ``calibench montecarlo arm-cmm --trials 2`` as a whole command (start,
  imports, the pool, the outputs and figure), and the arm's whole-command rate at 1000 trials;
- render-fidelity studies of the belt and vision stages (trials/s, whole study in this process);
- a study through a local Dask cluster against the local pool, the same workers
  (``dask_pool.py``);
- the renderer MuJoCo's EGL context reports (a GPU's, or Mesa's llvmpipe on the CPU).
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

GOALS = {
    "camera_ratio": 1.5,  # calibench camera / OpenCV's classic pipeline, whole commands
    "fixed_s": 1.0,  # a study's start, imports, pool and figure, 2 cores
    "arm_rate": 400.0,  # the arm study's whole-command trials/s, 2 cores
    "belt-stage": 1.0,  # render-fidelity trials/s, 2 cores
    "vision-stage": 0.3,
    "dask_ratio": 1.10,  # Dask / local pool, the same workers
}
CLI = [sys.executable, "-m", "calibench.scenarios.cli"]


def _timed(cmd: list[str]) -> float:
    t = time.perf_counter()
    subprocess.run(cmd, check=True, capture_output=True, env={**os.environ, "MUJOCO_GL": "egl"})
    return time.perf_counter() - t


def camera_command(data: Path, rounds: int = 5) -> dict:
    """Seconds of ``calibench camera`` and of OpenCV's classic pipeline, each a whole command on
    OpenCV's 13 sample photos (medians of ``rounds``, alternated)."""
    photos = [str(p) for p in sorted((data / "opencv_left").glob("left*.jpg"))]
    ours, peer = [], []
    with tempfile.TemporaryDirectory() as d:
        for _ in range(rounds):
            peer.append(_timed([sys.executable, str(HERE / "opencv_classic.py"), *photos]))
            ours.append(
                _timed(
                    CLI
                    + ["camera", *photos, "--cols", "9", "--rows", "6", "--square-mm", "25"]
                    + ["--fix-aspect", "--out", str(Path(d) / "cam"), "--force"]
                )
            )
    return {"ours_s": float(np.median(ours)), "peer_s": float(np.median(peer)), "n": len(photos)}


def study_command(trials: int, rounds: int = 1) -> float:
    """Seconds of ``calibench montecarlo arm-cmm --trials N`` as a whole command, a fresh folder
    each time (median of ``rounds``)."""
    times = []
    for _ in range(rounds):
        with tempfile.TemporaryDirectory() as d:
            times.append(
                _timed(CLI + ["montecarlo", "arm-cmm", "--trials", str(trials), "--out", d + "/s"])
            )
    return float(np.median(times))


def rendered_rate(scenario: str, trials: int) -> float:
    """Trials/s of a render-fidelity study of ``scenario`` (whole study, all cores)."""
    from calibench.scenarios.study.montecarlo import run_study

    with tempfile.TemporaryDirectory() as d:
        t = time.perf_counter()
        run_study(scenario, trials, 0, "render", Path(d), progress=False)
        return trials / (time.perf_counter() - t)


def renderer() -> str:
    """What MuJoCo's EGL context renders with (GL_RENDERER)."""
    import mujoco

    from calibench.sim.offscreen import gl_renderer

    model = mujoco.MjModel.from_xml_string("<mujoco><worldbody/></mujoco>")
    return gl_renderer(model)


def measure(data: Path) -> dict:
    """Every goal's figure and its peer's."""
    from dask_pool import compare

    out = {"camera": camera_command(data), "renderer": renderer()}
    out["fixed_s"] = study_command(2, rounds=3)
    out["arm_rate"] = 1000 / study_command(1000)
    out["belt-stage"] = rendered_rate("belt-stage", 8)
    out["vision-stage"] = rendered_rate("vision-stage", 2)
    out["dask"] = compare(4000)
    return out


def rows(m: dict) -> list[tuple[str, str, str, str]]:
    """The performance table's rows for these goals: what, calibench, peer, ratio or goal."""
    c, dk = m["camera"], m["dask"]
    cores = os.cpu_count()
    out = [
        (
            f"`calibench camera` on OpenCV's {c['n']} sample photos, whole command (imports, "
            "intrinsics.json, camera.png)",
            f"{c['ours_s']:.2f} s",
            f"OpenCV's classic pipeline, whole script {c['peer_s']:.2f} s",
            f"{c['ours_s'] / c['peer_s']:.2f}x (goal {GOALS['camera_ratio']}x)",
        ),
        (
            "a study's fixed cost: `calibench montecarlo arm-cmm --trials 2` (start, imports, "
            "pool, outputs, figure)",
            f"{m['fixed_s']:.2f} s",
            "",
            f"goal {GOALS['fixed_s']:g} s",
        ),
        (
            f"`calibench montecarlo arm-cmm --trials 1000`, whole command, {cores} cores",
            f"{m['arm_rate']:.0f} trials/s",
            "",
            f"goal {GOALS['arm_rate']:g} trials/s",
        ),
    ]
    for name in ("belt-stage", "vision-stage"):
        out.append(
            (
                f"Monte Carlo, {name}, rendered (area-of-interest read-out), {cores} cores",
                f"{m[name]:.2f} trials/s",
                "",
                f"goal {GOALS[name]:g} trials/s",
            )
        )
    out += [
        (
            f"Monte Carlo, arm-cmm, {dk['trials']} trials through a local Dask cluster of "
            f"{dk['workers']} one-thread workers",
            f"{dk['dask_s']:.1f} s",
            f"the local pool of {dk['workers']} {dk['pool_s']:.1f} s"
            + ("" if dk["same"] else " (RESULTS DIFFER)"),
            f"{dk['dask_s'] / dk['pool_s']:.2f}x (goal {GOALS['dask_ratio']:.2f}x)",
        ),
        ("the renderer MuJoCo's EGL context reports", m["renderer"], "", ""),
    ]
    return out
