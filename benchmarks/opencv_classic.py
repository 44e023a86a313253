"""OpenCV's classic calibration, the peer of ``calibench camera``. As a script, ``python
benchmarks/opencv_classic.py PHOTO...`` (9 x 6 inner corners, 25 mm squares) is the peer's whole
command: it imports nothing but OpenCV and numpy, and prints fx and the RMS."""

import sys
from pathlib import Path

import cv2
import numpy as np


def opencv(paths, cols, rows, square_mm):
    """OpenCV's textbook calibration: (fx, rms)."""
    obj = np.zeros((cols * rows, 3), np.float32)
    obj[:, :2] = np.mgrid[:cols, :rows].T.reshape(-1, 2) * square_mm
    objs, imgs, size = [], [], None
    for p in paths:
        img = cv2.imread(str(p), cv2.IMREAD_GRAYSCALE)
        size = img.shape[::-1]
        ok, c = cv2.findChessboardCorners(img, (cols, rows))
        if ok:
            c = cv2.cornerSubPix(
                img,
                c,
                (5, 5),
                (-1, -1),
                (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 30, 1e-3),
            )
            objs.append(obj)
            imgs.append(c)
    rms, K, *_ = cv2.calibrateCamera(objs, imgs, size, None, None, flags=cv2.CALIB_FIX_ASPECT_RATIO)
    return K[0, 0], rms


if __name__ == "__main__":
    print(opencv([Path(p) for p in sys.argv[1:]], 9, 6, 25.0))
