"""Throughput of the belt-stage pieces on this machine: ``python benchmarks/belt_stage.py``.

Prints renders/s, detections/s, pose pipeline stations/s and whole runs per fidelity.
"""

import os
import platform
import time
from pathlib import Path
from tempfile import TemporaryDirectory

os.environ.setdefault("MUJOCO_GL", "egl")  # before mujoco is imported: renders without a display

import numpy as np  # noqa: E402

from calibench.estimators.camera.chessboard import find_chessboard_corners
from calibench.scenarios.belt_stage import scenario as belt_stage
from calibench.scenes.belt_stage import BeltStageGeometry
from calibench.sim.belt_stage import BeltStageSim, BeltStageTruth


def rate(fn, n):
    t = time.perf_counter()
    for i in range(n):
        fn(i)
    return n / (time.perf_counter() - t)


def cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def main():
    print(
        f"machine: {cpu_model()}, {os.cpu_count()} cores, "
        f"python {platform.python_version()}, MUJOCO_GL={os.environ.get('MUJOCO_GL')}"
    )
    g = BeltStageGeometry()
    s = BeltStageSim(g, BeltStageTruth())
    xs = np.linspace(0, 245_000, 16).astype(int)
    cfg = belt_stage.BeltStageConfig()
    rng = np.random.default_rng(0)

    def frame(i):
        s.move(xs[i], xs[i])
        return s.render(rng=rng, noise_dn=cfg.pixel_noise_dn, psf_px=cfg.psf_px)

    print(f"render (640x480, 2x supersampled, lens, blur, noise): {rate(frame, 16):6.1f} frames/s")
    img = frame(0)
    print(
        "chessboard detection + saddle refinement: "
        f"{rate(lambda i: find_chessboard_corners(img, 9, 6), 16):6.1f} images/s"
    )
    s.close()
    with TemporaryDirectory() as d:
        for fidelity, n in (("analytic", 3), ("render", 1)):
            t = time.perf_counter()
            for seed in range(n):
                belt_stage.run(cfg, seed, fidelity, Path(d), rrd=False)
            print(f"whole run, {fidelity:8s}: {(time.perf_counter() - t) / n:6.1f} s per run")


if __name__ == "__main__":
    main()
