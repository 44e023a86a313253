"""OpenCV's classic calibration as a whole script, the peer of ``calibench camera``:
``python benchmarks/opencv_classic.py PHOTO...`` (9 x 6 inner corners, 25 mm squares) prints fx
and the RMS."""

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from camera import opencv  # noqa: E402

if __name__ == "__main__":
    print(opencv([Path(p) for p in sys.argv[1:]], 9, 6, 25.0))
