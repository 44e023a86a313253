"""``fit arm-cmm --leave-one-out`` on the four UR10 series (docs/arm-cmm.md's command): its run
time on this machine. ``python benchmarks/arm_sessions.py [--effects discover] [--out DIR]``.

The command runs as its own process, as a user runs it; its time is the wall clock and the CPU
of the process and its fold workers together (``wait4``'s, which adds the children it waited
for), and the machine is said with its load before the run (on a machine other jobs share the
same CPU takes a longer wall clock). Each session's held-out figures follow: the README's table
(docs/arm-cmm.md, "each series left out"), to check against it.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
UR10 = REPO / "data" / "ur10_landgraf"


def cpu_model() -> str:
    """The processor's name (Linux's /proc/cpuinfo), else what platform says."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def leave_one_out(out: Path, effects: str | None) -> tuple[float, float, float]:
    """Run the command into ``out``: (wall s, user CPU s, system CPU s)."""
    argv = [str(UR10 / f"ur10_{s}.csv") for s in "ABCD"]
    argv += ["--arm", str(UR10 / "ur10.toml"), "--leave-one-out", "--out", str(out), "--force"]
    argv += ["--effects", effects] if effects else []
    env = dict(os.environ, CALIBENCH_PROGRESS="plain")  # its progress lines, as off a terminal
    t = time.perf_counter()
    with tempfile.TemporaryFile("w+") as err:
        proc = subprocess.Popen(
            [sys.executable, "-m", "calibench.scenarios.cli", "fit", "arm-cmm", *argv],
            cwd=REPO,
            env=env,
            stdout=subprocess.DEVNULL,
            stderr=err,
        )
        # the command's and its fold workers' CPU: wait4 adds the children it waited for
        _, status, usage = os.wait4(proc.pid, 0)
        wall = time.perf_counter() - t
        proc.returncode = os.waitstatus_to_exitcode(status)
        if proc.returncode != 0:
            err.seek(0)
            said = err.read()[-600:]
            raise RuntimeError(f"fit arm-cmm --leave-one-out: exit {proc.returncode}: {said}")
    return wall, usage.ru_utime, usage.ru_stime


def main() -> None:
    """Run the command once and print the machine, its times and its figures."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--effects", help="as the command's --effects (discover)")
    parser.add_argument("--out", type=Path, help="the command's --out (default: a scratch one)")
    args = parser.parse_args()
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(
        f"machine: {cpu_model()}, {os.cpu_count()} cores, load average {load:.1f} before the "
        f"run; python {platform.python_version()}"
    )
    with tempfile.TemporaryDirectory() as scratch:
        out = args.out or Path(scratch) / "sessions"
        wall, user, system = leave_one_out(out, args.effects)
        fit = json.loads((out / "fit.json").read_text())
    effects = f" --effects {args.effects}" if args.effects else ""
    print(
        f"fit arm-cmm ur10_A..D --leave-one-out{effects}: {wall:.1f} s wall, "
        f"{user + system:.1f} s CPU ({user:.1f} user + {system:.1f} system, the fold workers "
        "included)"
    )
    for name, e in fit["leave_one_out"].items():
        print(f"  {name}: mean {e['mean_mm']:.3f} / max {e['max_mm']:.2f} mm (n = {e['samples']})")


if __name__ == "__main__":
    main()
