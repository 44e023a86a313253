"""The suite catches deliberate faults (issue 15): each fault of ``tests/sabotage.py`` applied in a
fresh pytest run of its target tests must turn one of them red through a failed assertion.

Each run is a subprocess (the faults patch the library for a whole session). The control runs
the plugin without a fault, so a plugin that broke the targets by itself cannot pass for a
catch; an unknown fault's name is a usage error, so a typo cannot either. Deselect the lot with
``-m "not sabotage"`` (about a minute and a half on two cores).
"""

import os
import subprocess
import sys
from pathlib import Path

import pytest

from tests.sabotage import ENV, FAULTS

REPO = Path(__file__).resolve().parents[1]
pytestmark = pytest.mark.sabotage


def _pytest(fault: str | None, targets) -> subprocess.CompletedProcess:
    """Run ``pytest -x -p tests.sabotage targets`` in the repository with ``fault`` applied (None:
    no fault).

    Parameters
    ----------
    fault : a name in ``FAULTS``, any other string, or None.
    targets : test node ids or files.

    Returns
    -------
    The finished process, its stdout and stderr as text.
    """
    env = {**os.environ, "MUJOCO_GL": "egl"}
    env.pop(ENV, None)
    if fault is not None:
        env[ENV] = fault
    # no cache: the deliberate failures must not become the next --lf's "last failed"
    cmd = [
        sys.executable,
        "-m",
        "pytest",
        "-q",
        "-x",
        "--tb=short",
        "-p",
        "no:cacheprovider",
        "-p",
        "tests.sabotage",
        *targets,
    ]
    return subprocess.run(cmd, cwd=REPO, env=env, capture_output=True, text=True, timeout=600)


# a fault no test catches yet is expected to pass unseen; once a test catches it, strict turns it
# red
PARAMS = [
    pytest.param(
        name,
        id=name,
        marks=[pytest.mark.xfail(strict=True, reason=f.uncaught)] if f.uncaught else [],
    )
    for name, f in FAULTS.items()
]


@pytest.mark.parametrize("name", PARAMS)
def test_the_suite_catches_the_fault(name):
    """Exit code 1 (tests failed; 2-4 would be an interrupted run, an internal or a usage error),
    the plugin says the fault was applied, and the failure is an assertion, not a crash."""
    run = _pytest(name, FAULTS[name].targets)
    tail = (run.stdout + run.stderr)[-3000:]
    assert f"sabotage: applied {name}" in run.stdout, tail
    assert run.returncode == 1, f"{name} went unseen (exit {run.returncode}):\n{tail}"
    assert "sabotage: assertion failed in " in run.stdout, tail


def test_without_a_fault_the_targets_pass():
    """The control: the same kind of run, the plugin loaded, no fault: every fault's targets pass
    (run on their own, as the faults run them, not only within the whole suite)."""
    targets = sorted({t for f in FAULTS.values() for t in f.targets})
    run = _pytest(None, targets)
    assert run.returncode == 0, (run.stdout + run.stderr)[-3000:]
    assert "sabotage: no fault applied" in run.stdout


def test_an_unknown_fault_is_a_usage_error():
    run = _pytest("no_such_fault", FAULTS["map_xy_term_dropped"].targets)
    assert run.returncode == 4, (run.stdout + run.stderr)[-3000:]
    assert "no such fault" in run.stdout + run.stderr
