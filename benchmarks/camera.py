"""``calibench camera`` against OpenCV's classic pipeline on the same photos.

``python benchmarks/camera.py [DATA]`` (DATA: the real data's folder, default the project's data/)
times, on OpenCV's 13 ``left*.jpg`` sample photos (9 x 6 inner corners), interleaved over 5
rounds so that both see the same machine state:

- OpenCV: ``findChessboardCorners`` + ``cornerSubPix`` (11 x 11 window) + ``calibrateCamera``;
- calibench: ``calibrate_photos`` (the classic detector, the saddle refinement, the grid check,
  ``calibrateCameraExtended`` with the std, the fixed-aspect covariance).

It prints the median time of each, their ratio, and both focal lengths and RMS.
"""

import os
import platform
import sys
import time
from pathlib import Path

import cv2
import numpy as np
from opencv_classic import opencv  # the peer, a whole script of its own in goals.py

from calibench.scenarios.camera import calibrate_photos


def main():
    data = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).resolve().parents[1] / "data"
    paths = sorted((data / "opencv_left").glob("left*.jpg"))
    print(
        f"{platform.processor() or platform.machine()}, {os.cpu_count()} cores, OpenCV "
        f"{cv2.__version__}, {len(paths)} photos"
    )
    t_cv, t_cb = [], []
    for _ in range(5):
        t0 = time.perf_counter()
        fx_cv, rms_cv = opencv(paths, 9, 6, 25.0)
        t_cv.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        r = calibrate_photos(paths, 9, 6, 25.0, fix_aspect=True)
        t_cb.append(time.perf_counter() - t0)
    a, b = np.median(t_cv), np.median(t_cb)
    print(f"OpenCV classic     {1000 * a:7.0f} ms  fx {fx_cv:.3f}  rms {rms_cv:.3f} px")
    print(f"calibench camera   {1000 * b:7.0f} ms  fx {r['K'][0][0]:.3f}  rms {r['rms_px']:.3f} px")
    print(f"ratio              {b / a:7.2f} x")


if __name__ == "__main__":
    main()
