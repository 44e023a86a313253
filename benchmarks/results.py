"""The README's performance table, measured in one run on this machine: ``python
benchmarks/results.py`` prints it (``python -m docs.figures performance`` writes it into the
README).

Each row sets calibench beside its peer measured in the same run, interleaved where it is cheap:
the bare MuJoCo renderer for the lens render, OpenCV's classic pipeline for ``calibench camera``,
pybotics' approach (scipy's Levenberg-Marquardt over the same residuals with a finite-difference
Jacobian) for the arm's identification; and each scenario's analytic Monte-Carlo study on all
cores, run from this process (its pool's start in, a fresh Python's imports not: the arm's whole
command is issue 39's row), beside issue 16's goal; then issue 39's goals (``goals.py``): whole
commands, a study's fixed cost, rendered studies, Dask against the pool, and the renderer in use.

pybotics itself (3.1.2, its ``OptimizationHandler`` with every chain parameter free) did not
converge on a UR10 of 100 postures in 2000 evaluations (6 minutes) here, so it is not a row.
"""

from __future__ import annotations

import os
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")  # before mujoco is imported: renders without a display

import numpy as np  # noqa: E402

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

# trials per study, and the trials/s on 2 cores issue 16 asks for
STUDIES = {
    "arm-cmm": (1000, 200),
    "stewart": (200, 10),
    "belt-stage": (100, 8),
    "probe-scanner": (40, 5),
    "vision-stage": (60, 3),
}


def machine() -> str:
    """CPU model and core count."""
    from belt_stage import cpu_model

    return f"{cpu_model()}, {os.cpu_count()} cores"


def render(n: int = 16) -> dict:
    """ms per frame: the belt stage's camera through its lens (2x supersampled, the lens's
    distortion, blur, noise) against MuJoCo's bare 640 x 480 frame of the same scene, alternated."""
    import mujoco

    from calibench.scenarios.belt_stage import scenario as belt_stage
    from calibench.scenes.belt_stage import BeltStageGeometry
    from calibench.sim.belt_stage import BeltStageSim, BeltStageTruth

    cfg = belt_stage.BeltStageConfig()
    sim = BeltStageSim(BeltStageGeometry(), BeltStageTruth())
    cam = sim.renderer.camera_id
    bare = mujoco.Renderer(sim.model, 480, 640)
    rng = np.random.default_rng(0)
    xs = np.linspace(0, 245_000, n).astype(int)
    ours, peer, window = [], [], []
    for i in range(n + 1):  # the first frame of each warms up
        sim.move(xs[i % n], xs[i % n])
        t = time.perf_counter()
        sim.render(rng=rng, noise_dn=cfg.pixel_noise_dn, psf_px=cfg.psf_px)
        t1 = time.perf_counter()
        bare.update_scene(sim.data, camera=cam)
        bare.render()
        t2 = time.perf_counter()
        sim.render(False, rng, cfg.pixel_noise_dn, cfg.psf_px, sim.board_window())
        t3 = time.perf_counter()
        if i:
            ours.append(t1 - t)
            peer.append(t2 - t1)
            window.append(t3 - t2)
    bare.close()
    sim.close()
    return {
        "ours_ms": 1000 * float(np.median(ours)),
        "peer_ms": 1000 * float(np.median(peer)),
        "window_ms": 1000 * float(np.median(window)),
    }


def camera(data: Path, rounds: int = 5) -> dict:
    """ms for OpenCV's 13 sample photos: calibench camera against OpenCV's classic pipeline."""
    from opencv_classic import opencv

    from calibench.scenarios.camera import calibrate_photos

    paths = sorted((data / "opencv_left").glob("left*.jpg"))
    t_cv, t_cb = [], []
    for _ in range(rounds):
        t = time.perf_counter()
        opencv(paths, 9, 6, 25.0)
        t_cv.append(time.perf_counter() - t)
        t = time.perf_counter()
        calibrate_photos(paths, 9, 6, 25.0, fix_aspect=True)
        t_cb.append(time.perf_counter() - t)
    return {
        "ours_ms": 1000 * float(np.median(t_cb)),
        "peer_ms": 1000 * float(np.median(t_cv)),
        "photos": len(paths),
    }


def studies() -> dict:
    """Trials/s of each scenario's analytic study on all cores, run from this process: the pool's
    start and the outputs in, a fresh Python's start and imports not."""
    from calibench.scenarios.study.montecarlo import run_study

    out = {}
    for name, (n, goal) in STUDIES.items():
        with tempfile.TemporaryDirectory() as d:
            t = time.perf_counter()
            s = run_study(name, n, 0, "analytic", Path(d), progress=False)
            out[name] = {
                "trials": n,
                "rate": n / (time.perf_counter() - t),
                "goal": goal,
                "failed": s["failed"],
            }
    return out


def table(data: Path) -> str:
    """The README's table (markdown) and the machine it was measured on."""
    from arm_cmm import ur10_physics
    from goals import compile_bytecode
    from threadpoolctl import threadpool_limits

    compile_bytecode()
    r, c = render(), camera(data)
    with threadpool_limits(1):
        arm = ur10_physics(quiet=True)
    st = studies()
    rows = [
        (
            "render 640x480 through the lens (2x supersampled, distortion, blur, noise)",
            f"{r['ours_ms']:.0f} ms",
            f"MuJoCo's bare 640x480 frame {r['peer_ms']:.0f} ms",
            f"{r['ours_ms'] / r['peer_ms']:.1f}x",
        ),
        (
            "the same, the board's area of interest only (a study's read-out)",
            f"{r['window_ms']:.1f} ms",
            f"MuJoCo's bare 640x480 frame {r['peer_ms']:.0f} ms",
            f"{r['window_ms'] / r['peer_ms']:.2f}x",
        ),
        (
            f"`calibench camera` on OpenCV's {c['photos']} sample photos (0.01 px corners, "
            "gross-corner check, std)",
            f"{c['ours_ms']:.0f} ms",
            f"OpenCV's classic pipeline {c['peer_ms']:.0f} ms",
            f"{c['ours_ms'] / c['peer_ms']:.2f}x",
        ),
        (
            f"UR10 identification with physics, {arm['n']} poses, {arm['k']} parameters, one "
            "thread",
            f"{arm['ours_s']:.2f} s (analytic Jacobian)",
            f"pybotics' approach (scipy's LM, finite differences) {arm['peer_s']:.1f} s, the same "
            f"cost to {abs(arm['cost_ours'] / arm['cost_peer'] - 1):.0e}",
            f"{arm['ours_s'] / arm['peer_s']:.3f}x",
        ),
    ]
    for name, s in st.items():
        rows.append(
            (
                f"Monte Carlo, {name}, analytic, {s['trials']} trials ({os.cpu_count()} cores, "
                "a study from a running Python: its pool's start in)",
                f"{s['rate']:.1f} trials/s",
                f"goal {s['goal']} trials/s",
                f"{s['rate'] / s['goal']:.2f} of the goal",
            )
        )
    from goals import measure
    from goals import rows as goal_rows

    rows += goal_rows(measure(data))
    lines = [
        f"Measured on {machine()} by `python benchmarks/results.py` (the package's bytecode "
        "compiled first, as `pip install` does).",
        "",
        "| what | calibench | peer, same run | ratio |",
        "|---|---|---|---|",
    ]
    lines += [f"| {a} | {b} | {p} | {q} |" for a, b, p, q in rows]
    return "\n".join(lines)


def main() -> None:
    data = Path(sys.argv[1]) if len(sys.argv) > 1 else HERE.parent / "data"
    print(table(data))


if __name__ == "__main__":
    main()
