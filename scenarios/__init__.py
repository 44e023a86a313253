"""Experiments: wire scene, sim and estimators, compare Estimate with Truth, report, CLI.

Runs are reproducible to the last bit from their seed: OpenCV's multithreaded reductions
(calibration, PnP) are not, so OpenCV runs single-threaded in any process that runs scenarios.
"""

import cv2

cv2.setNumThreads(1)
