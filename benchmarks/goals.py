"""Issue 39's goals, each measured beside its peer in the same run (``results.py`` prints them).

- ``calibench camera`` as a whole command (a fresh Python: imports, photos, intrinsics.json,
  camera.png) against OpenCV's classic pipeline as a whole script, alternated;
- a study's fixed cost: ``calibench montecarlo arm-cmm --trials 1000`` as a whole command less
  its trials' own time over the cores (start, imports, the pool, the outputs and figure), beside
  its floor (a fresh Python, a worker's imports, the figure library's), and the same command's
  rate;
- render-fidelity studies of the belt and vision stages (trials/s, whole study in this process);
- a rendered ``run belt-stage`` in this process, its frames developed on the other cores while
  the next renders, against the same run developing each frame in turn;
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
# a rendered study's trials: a few a core, so that the rate is the study's, not its start's
RENDERED_TRIALS = {"belt-stage": 16, "vision-stage": 6}
CLI = [sys.executable, "-m", "calibench.scenarios.cli"]
SOURCES = ("calibench", "estimators", "scenarios", "scenes", "sim")  # the package's directories


def compile_bytecode() -> None:
    """Every module of the package compiled to bytecode, as ``pip install`` does: where
    PYTHONDONTWRITEBYTECODE is set (this project's build machine) nothing is ever cached, and
    every whole command would compile each module it imports, and time that, at its start."""
    import compileall

    for d in SOURCES:
        compileall.compile_dir(HERE.parent / d, quiet=1, workers=0)


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


def study_command(trials: int, rounds: int = 3) -> dict:
    """``calibench montecarlo arm-cmm --trials N`` as a whole command: its seconds, and its fixed
    cost, those seconds less the trials' own (their summed time over the cores). Of ``rounds``
    runs, the one with the median seconds: one run on a shared 2-core machine can be a third off
    the next."""
    import json

    runs = []
    for _ in range(rounds):
        with tempfile.TemporaryDirectory() as d:
            argv = ["montecarlo", "arm-cmm", "--trials", str(trials), "--out", d + "/s"]
            whole = _timed(CLI + argv)
            rows = (Path(d) / "s" / "trials.jsonl").read_text().splitlines()
            busy = sum(json.loads(r)["elapsed_s"] for r in rows if r.strip())
        runs.append({"whole_s": whole, "fixed_s": whole - busy / min(os.cpu_count() or 1, trials)})
    return {**sorted(runs, key=lambda r: r["whole_s"])[len(runs) // 2], "rounds": rounds}


def floor() -> dict:
    """What a study cannot start without, each in a fresh Python: a worker's imports for the
    arm's trials (numpy, scipy, MuJoCo, the estimators), and the figure's library."""
    worker = "from calibench.scenarios.study.trials import load_scenario; load_scenario('arm-cmm')"
    figure = "import cv2"  # study.png is drawn with OpenCV
    return {
        "python_s": float(np.median([_timed([sys.executable, "-c", "pass"]) for _ in range(3)])),
        "worker_s": float(np.median([_timed([sys.executable, "-c", worker]) for _ in range(3)])),
        "figure_s": float(np.median([_timed([sys.executable, "-c", figure]) for _ in range(3)])),
    }


def arm_trial_ms(n: int = 200) -> float:
    """ms of one analytic arm trial in this process, warm (the median of ``n`` trials' own
    times, as each study row records them): the unit of the arm study's ceiling."""
    from calibench.scenarios.study.trials import run_trial

    run_trial("arm-cmm", 0, 0, "analytic")  # the scenario's imports and first model
    times = []
    for seed in range(1, n + 1):
        t = time.perf_counter()
        run_trial("arm-cmm", seed, 0, "analytic")
        times.append(time.perf_counter() - t)
    return 1000 * float(np.median(times))


def arm_ceiling(m: dict, trials: int = 1000) -> float:
    """The most trials/s the arm's whole command could reach at this run's trial cost: a fresh
    Python and one worker's imports (the workers start together), then ``trials`` trials shared
    by the cores with nothing else running (no contention, no journal, no outputs, no figure): an
    upper bound, which the command's own rate stays under."""
    cores = os.cpu_count() or 1
    start = m["floor"]["python_s"] + m["floor"]["worker_s"]
    return trials / (start + trials * m["arm_trial_ms"] / 1000 / min(cores, trials))


def rendered_rate(scenario: str, trials: int) -> float:
    """Trials/s of a render-fidelity study of ``scenario`` (whole study, all cores)."""
    from calibench.scenarios.study.montecarlo import run_study

    with tempfile.TemporaryDirectory() as d:
        t = time.perf_counter()
        run_study(scenario, trials, 0, "render", Path(d), progress=False)
        return trials / (time.perf_counter() - t)


def rendered_run(rounds: int = 3) -> dict:
    """Seconds of a rendered ``run belt-stage`` (seed 0, in this process, no rerun log), its
    frames developed on :func:`~calibench.sim.frame_workers.frame_workers` threads while the next
    renders, and developed in turn; medians of ``rounds``, alternated."""
    from calibench.scenarios.belt_stage import scenario as belt_stage

    config = belt_stage.BeltStageConfig()
    original = belt_stage.frame_workers
    workers = original()
    times: dict[int, list[float]] = {workers: [], 0: []}
    with tempfile.TemporaryDirectory() as d:
        belt_stage.run(config, 0, "render", Path(d), rrd=False)  # the lens's maps, GL's start
        try:
            for _ in range(rounds):
                for w in times:
                    belt_stage.frame_workers = lambda w=w: w  # type: ignore[misc]
                    t = time.perf_counter()
                    belt_stage.run(config, 0, "render", Path(d), rrd=False)
                    times[w].append(time.perf_counter() - t)
        finally:
            belt_stage.frame_workers = original  # type: ignore[misc]
    return {
        "workers": workers,
        "threaded_s": float(np.median(times[workers])),
        "in_turn_s": float(np.median(times[0])),
    }


def vision_floor() -> dict:
    """The vision stage's rendered trial as frames: how many one trial renders, MuJoCo's bare
    render of one (the microscope's padded frame, nothing after it), and the floor no faster
    code under today's images avoids: the render of a trial's area of interest and the sensor's
    noise draws over it. The cores can do at most cores / (frames x floor) trials/s whatever
    else a frame costs."""
    from calibench.scenarios.study.trials import run_trial
    from calibench.sim import renderer as lens

    windows = []
    original = lens.LensRenderer.render

    def counted(self, data, rng=None, noise_dn=0.0, psf_px=0.0, window=None):
        windows.append(window)
        return original(self, data, rng, noise_dn, psf_px, window)

    lens.LensRenderer.render = counted  # type: ignore[method-assign]
    try:
        run_trial("vision-stage", 0, 0, "render")
    finally:
        lens.LensRenderer.render = original  # type: ignore[method-assign]
    from calibench.scenes.vision_stage import VisionStageGeometry
    from calibench.sim.vision_stage import VisionStageSim, VisionStageTruth

    sim = VisionStageSim(VisionStageGeometry(), VisionStageTruth(), np.random.default_rng(0))
    r = sim.renderer
    w, h = r._size
    window = windows[len(windows) // 2]
    shape = (window[3] - window[1], window[2] - window[0])
    rng = np.random.default_rng(0)
    bare, read_out, draws = [], [], []
    for _ in range(21):
        t0 = time.perf_counter()
        r._offscreen.render(sim.data, r.camera_id, r.option, w, h)
        t1 = time.perf_counter()
        r.render(sim.data, window=window)
        t2 = time.perf_counter()
        rng.normal(0.0, 1.0, shape)
        t3 = time.perf_counter()
        bare.append(t1 - t0), read_out.append(t2 - t1), draws.append(t3 - t2)
    sim.close()
    ms = {
        k: 1000 * float(np.median(v[1:]))
        for k, v in (("bare_ms", bare), ("window_ms", read_out), ("noise_ms", draws))
    }
    return {"frames": len(windows), "window": f"{shape[1]}x{shape[0]}", **ms}


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
    arm = study_command(1000)
    out["fixed_s"], out["arm_rate"], out["floor"] = arm["fixed_s"], 1000 / arm["whole_s"], floor()
    out["study_rounds"] = arm["rounds"]
    out["arm_trial_ms"] = arm_trial_ms()
    for name, n in RENDERED_TRIALS.items():
        out[name] = rendered_rate(name, n)
    out["vision_floor"] = vision_floor()
    out["rendered_run"] = rendered_run()
    out["dask"] = compare()
    return out


def rows(m: dict) -> list[tuple[str, str, str, str]]:
    """The performance table's rows for these goals: what, calibench, peer, ratio or goal."""
    c, dk, rr = m["camera"], m["dask"], m["rendered_run"]
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
            "a study's fixed cost: the arm's 1000-trial study less its trials' time over the "
            f"cores (start, imports, pool, outputs, figure; the median of {m['study_rounds']} "
            "runs)",
            f"{m['fixed_s']:.2f} s",
            f"its floor, each in a fresh Python: Python {m['floor']['python_s']:.2f} s, a "
            f"worker's imports {m['floor']['worker_s']:.2f} s, OpenCV for the figure "
            f"{m['floor']['figure_s']:.2f} s",
            f"goal {GOALS['fixed_s']:g} s",
        ),
        (
            f"`calibench montecarlo arm-cmm --trials 1000`, whole command, {cores} cores (the same "
            "run)",
            f"{m['arm_rate']:.0f} trials/s",
            f"its ceiling at this run's trial ({m['arm_trial_ms']:.1f} ms in one process): a "
            f"fresh Python and a worker's imports, then 1000 trials over {cores} cores with "
            f"nothing else running, {arm_ceiling(m):.0f} trials/s",
            f"goal {GOALS['arm_rate']:g} trials/s",
        ),
    ]
    vf = m["vision_floor"]
    floor_ms = vf["window_ms"] + vf["noise_ms"]
    ceiling = (cores or 1) / (vf["frames"] * floor_ms / 1000)
    for name, peer in (
        ("belt-stage", ""),
        (
            "vision-stage",
            f"its ceiling: {vf['frames']} frames a trial x ({vf['window']} px rendered and "
            f"quantised {vf['window_ms']:.1f} ms + its noise drawn {vf['noise_ms']:.1f} ms) = "
            f"{ceiling:.2f} trials/s on {cores} cores (MuJoCo's bare full frame "
            f"{vf['bare_ms']:.1f} ms)",
        ),
    ):
        out.append(
            (
                f"Monte Carlo, {name}, rendered (area-of-interest read-out), "
                f"{RENDERED_TRIALS[name]} trials, {cores} cores",
                f"{m[name]:.2f} trials/s",
                peer,
                f"goal {GOALS[name]:g} trials/s",
            )
        )
    out += [
        (
            f"Monte Carlo, arm-cmm, {dk['trials']} trials through a local Dask cluster of "
            f"{dk['workers']} one-thread workers ({dk['rounds']} rounds in turn with the pool, "
            "each first in every other: medians)",
            f"{dk['dask_s']:.1f} s",
            f"the local pool of {dk['workers']} {dk['pool_s']:.1f} s"
            + ("" if dk["same"] else " (RESULTS DIFFER)"),
            f"{dk['ratio']:.2f}x (goal {GOALS['dask_ratio']:.2f}x)",
        ),
        (
            "`run belt-stage`, rendered (141 frames through the lens, 2x supersampled), in one "
            f"process: each frame developed (lens, blur, noise, corners) on {rr['workers']} "
            f"thread{'s' if rr['workers'] != 1 else ''} while the next renders",
            f"{rr['threaded_s']:.2f} s",
            f"the same run, each frame developed in turn {rr['in_turn_s']:.2f} s",
            f"{rr['in_turn_s'] / rr['threaded_s']:.2f}x faster (goal: 3x against 2 CPU cores "
            "where a GPU renders)",
        ),
        ("the renderer MuJoCo's EGL context reports", m["renderer"], "", ""),
    ]
    return out
