"""Pure algorithms: a recording in, an estimate with its covariance out (numpy, scipy, cv2 only).

One package per instrument (``arm``, ``probe_scanner``, ``stewart``), the image chain both stages
share (``camera``), the stages' error maps (``stage``), and one engine per idea: ``identification``
(problem protocol, solver, identifiable basis, covariance) and ``discovery`` (the engine and each
instrument's candidate effects). ``rotations`` holds the rotations every room shares, ``quantiles``
numpy's percentile and median without their import of numpy.ma.
"""
