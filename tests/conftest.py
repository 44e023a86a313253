import os
from pathlib import Path

import pytest

os.environ.setdefault("MUJOCO_GL", "egl")

import cv2  # noqa: E402

# the tests call scenarios' run() directly: the same single-threaded OpenCV as Scenario.execute
cv2.setNumThreads(1)

REPO = Path(__file__).resolve().parents[1]
SHARED_DATA = REPO.parent / "shared" / "data"


@pytest.fixture(scope="session")
def shared_data() -> Path:
    if not SHARED_DATA.is_dir():
        pytest.fail(f"shared data not found at {SHARED_DATA} (a clone of main needs shared/ beside it)")
    return SHARED_DATA
