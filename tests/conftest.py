import os
from pathlib import Path

import pytest

os.environ.setdefault("MUJOCO_GL", "egl")
# A command past 10 s says progress lines on stderr: a test that counts stderr's lines must not
# depend on the machine's speed (tests/scenarios/test_progress.py sets its own mode).
os.environ.setdefault("CALIBENCH_PROGRESS", "off")
# One BLAS thread per process: the workers (pytest-xdist) already fill the cores, and the
# discoveries' own thread pools on top of a BLAS pool per thread ran the Stewart suites 2-4 times
# slower on 2 cores. Set before numpy loads, and inherited by the commands the tests start.
for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

# calibench before cv2: importing it sets OpenCV's decoding limit, which cv2 reads as it loads
import calibench  # noqa: E402, F401

# isort: split
import cv2  # noqa: E402

# the tests call scenarios' run() directly: the same single-threaded OpenCV as Scenario.execute
cv2.setNumThreads(1)

REPO = Path(__file__).resolve().parents[1]
REAL_DATA = REPO / "data"  # the real datasets, with their licences in data/LICENSES.md


SLOW_LIST = Path(__file__).with_name("slow_tests.txt")


def slow_tests() -> dict[str, float]:
    """The tests ``make test`` leaves to ``make test-slow`` (tests/slow_tests.txt: node ids, a
    test function's for all its parameters or one parameter's, with the seconds they took when
    measured)."""
    out = {}
    for line in SLOW_LIST.read_text().splitlines():
        line = line.partition("#")[0]
        if line.strip():
            seconds, node = line.split()
            out[node] = float(seconds)
    return out


def pytest_collection_modifyitems(session, config, items):
    """Mark the listed tests ``slow``: ``make test`` runs ``-m "not slow"`` in minutes, and CI
    runs the slow ones too (``make test-slow``). The longest modules go first (a README figures
    group counts as a module of its own), so that the workers that take tests as they free up
    end together instead of one waiting on the last long test."""
    slow = slow_tests()
    seconds: dict[str, float] = {}
    for item in items:
        own = slow.get(item.nodeid, slow.get(item.nodeid.partition("[")[0], 0.0))
        if own:
            item.add_marker(pytest.mark.slow)
        seconds[_unit(item)] = seconds.get(_unit(item), 0.0) + own + _figure_seconds(item)
    items.sort(key=lambda item: -seconds[_unit(item)])  # stable: a module's order kept


def _unit(item) -> str:
    """What runs together: a module, or one README figures group (a process of its own)."""
    return item.nodeid if _figure_seconds(item) else item.nodeid.partition("::")[0]


def _figure_seconds(item) -> float:
    """A README figures group's expected seconds (its blocks' own), else 0."""
    names = getattr(getattr(item, "callspec", None), "params", {}).get("names")
    if not names or not item.nodeid.startswith("tests/test_readme_figures.py"):
        return 0.0
    from docs.figures import BLOCKS

    return sum(BLOCKS[n].seconds for n in names)


@pytest.fixture(scope="session")
def real_data() -> Path:
    if not REAL_DATA.is_dir():
        pytest.fail(
            f"real data not found at {REAL_DATA} (the project's data/ folder, part of every clone)"
        )
    return REAL_DATA


@pytest.fixture(scope="session")
def stewart_null_rms() -> float:
    """The Stewart platform's noise as discover measures it: the cross-validated RMS (mm) of a null
    recording (no effect concealed, nothing chosen beyond the scene model's geometry, so held out
    for every structure), the level a found effect should leave behind."""
    from calibench.scenarios.stewart.discovery import discover_stewart
    from calibench.sim.concealed import stewart_recording

    out, _ = discover_stewart(stewart_recording("null", 4)[0], 0)
    assert [e["name"] for e in out["effects"]] == ["geometry"]
    return out["fit"]["cv_rms_final"]
