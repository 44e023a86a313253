import os
import subprocess
import tempfile
from pathlib import Path

import pytest

os.environ.setdefault("MUJOCO_GL", "egl")

import cv2  # noqa: E402

# the tests call scenarios' run() directly: the same single-threaded OpenCV as Scenario.execute
cv2.setNumThreads(1)

REPO = Path(__file__).resolve().parents[1]
REAL_DATA = REPO / "data"  # the real datasets, with their licences in data/LICENSES.md


@pytest.fixture(scope="session")
def real_data() -> Path:
    if not REAL_DATA.is_dir():
        pytest.fail(
            f"real data not found at {REAL_DATA} (the project's data/ folder, part of every clone)"
        )
    return REAL_DATA


FIGURES_TEST = "tests/test_readme_figures.py::test_the_readme_agrees_with_the_code"
FIGURES_CHECK = pytest.StashKey()  # (process, its log) of the check started at collection


@pytest.hookimpl(trylast=True)  # after -k and -m have deselected
def pytest_collection_modifyitems(session, config, items):
    """The README-figures check (half an hour of the project's own commands, one process) starts
    now, beside the rest of the suite, and its test collects the result: on 2 cores the whole
    suite then takes about as long as that check alone."""
    wanted = any(item.nodeid == FIGURES_TEST for item in items)
    if wanted and REAL_DATA.is_dir() and not config.option.collectonly:
        from tests.test_readme_figures import figures_check_command

        log = tempfile.TemporaryFile("w+")
        proc = subprocess.Popen(
            figures_check_command(), cwd=REPO, stdout=log, stderr=subprocess.STDOUT, text=True
        )
        config.stash[FIGURES_CHECK] = (proc, log)


def pytest_sessionfinish(session, exitstatus):
    """A check the session did not wait for (a -x stop, an interrupt) does not outlive it."""
    started = session.config.stash.get(FIGURES_CHECK, None)
    if started and started[0].poll() is None:
        started[0].kill()
        started[0].wait()


def figures_check_result(config) -> tuple[int, str]:
    """The README-figures check's exit status and printout: the one started at collection, or
    one run now (the test run alone)."""
    from tests.test_readme_figures import figures_check_command

    started = config.stash.get(FIGURES_CHECK, None)
    if started is None:
        r = subprocess.run(figures_check_command(), cwd=REPO, capture_output=True, text=True)
        return r.returncode, r.stdout + r.stderr
    proc, log = started
    proc.wait()
    log.seek(0)
    return proc.returncode, log.read()


@pytest.fixture(scope="session")
def stewart_null_rms() -> float:
    """The Stewart platform's noise as discover measures it: the cross-validated RMS (mm) of a null
    recording (no effect concealed, nothing chosen beyond the scene model's geometry, so held out
    for every structure), the level a found effect should leave behind."""
    from calibench.scenarios.discover.stewart import discover_stewart
    from calibench.sim.concealed import stewart_recording

    out, _ = discover_stewart(stewart_recording("null", 4)[0], 0)
    assert [e["name"] for e in out["effects"]] == ["geometry"]
    return out["fit"]["cv_rms_final"]
