"""A rendered ``run belt-stage`` on this machine, alone: ``python benchmarks/rendered_run.py``.

Prints the machine, what MuJoCo's EGL context renders with, and the run's seconds with its frames
developed on the other cores and developed in turn (``goals.rendered_run``): the check to run
where a GPU renders (issue 39 asks 3x against 2 CPU cores; ``results.py`` prints the 2-core
figure in its table), in about a minute.
"""

import os
import sys
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")  # before mujoco is imported: renders without a display

sys.path.insert(0, str(Path(__file__).resolve().parent))

from belt_stage import cpu_model  # noqa: E402
from goals import rendered_run, renderer  # noqa: E402


def main() -> None:
    print(f"machine: {cpu_model()}, {os.cpu_count()} cores; renderer: {renderer()}")
    r = rendered_run()
    print(
        f"run belt-stage, rendered, in one process: {r['threaded_s']:.2f} s with its frames "
        f"developed on {r['workers']} thread{'s' if r['workers'] != 1 else ''}, "
        f"{r['in_turn_s']:.2f} s developed in turn"
    )


if __name__ == "__main__":
    main()
