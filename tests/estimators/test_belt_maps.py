"""The belt stage's maps from station views (estimators.stage.belt_maps): corners projected by
OpenCV from a known board path give back the injected error maps and board yaw within their
std, and the std that carries the intrinsics' covariance into the maps is honest."""

import cv2
import numpy as np

from calibench.estimators.stage.belt_maps import (
    MAP_INTRINSICS,
    measure_maps,
    propagated_std,
)

K = np.array([[1500.0, 0, 639.5], [0, 1500.0, 479.5], [0, 0, 1]])
DIST = np.array([-0.1, 0.05, 0.0, 0.0, 0.0])
NOISE_PX = 0.02  # the detector's noise per axis
# the board: 9 x 7 corners at 25 mm, x along machine X and y along -Y, yawed about +Z
BOARD = np.array([[i * 25.0, j * 25.0, 0.0] for j in range(7) for i in range(9)])
YAW_RAD = 3e-3
X_CAM, Y_CAM = np.array([1.0, 0, 0]), np.array([0, -1.0, 0])
# the stations, home first; the maps c0..c5 (mm, mm/mm, mm/mm^2), c0 = 0 by homing
XS, YS = (0.0, 60.0, 140.0, 210.0, 300.0), (0.0, 50.0, 110.0, 200.0)
EX = np.array([0.0, 2e-3, -1e-3, 4e-6, 3e-6, -2e-6])
EY = np.array([0.0, -1.5e-3, 2.5e-3, -3e-6, 2e-6, 5e-6])
# the intrinsics' covariance (MAP_INTRINSICS' order), a Zhang calibration's from some 20 views
COV_INTR = np.diag(np.array([0.1, 0.1, 0.08, 0.08, 2e-4, 5e-4, 2e-5, 2e-5]) ** 2)


def _quadratic(c, x, y):
    return c[0] + c[1] * x + c[2] * y + c[3] * x * x + c[4] * x * y + c[5] * y * y


def _stations(rng):
    """Commands (n, 2) mm and each station's corners (n, 63, 2) px, projected by OpenCV."""
    gx, gy = np.meshgrid(XS, YS)
    cmd = np.stack([gx.ravel(), gy.ravel()], axis=1)
    actual = cmd + np.stack([_quadratic(EX, *cmd.T), _quadratic(EY, *cmd.T)], axis=1)
    R = cv2.Rodrigues(np.array([0.0, 0.0, -YAW_RAD]))[0]  # +Z is the camera's -z
    centroid = np.array([-150.0, 100.0, 900.0]) + actual @ np.stack([X_CAM, Y_CAM])
    t = centroid - R @ BOARD.mean(axis=0)
    rvec = cv2.Rodrigues(R)[0]
    corners = np.stack([cv2.projectPoints(BOARD, rvec, ti, K, DIST)[0][:, 0] for ti in t])
    return cmd, corners + rng.normal(0, NOISE_PX, corners.shape)


def _truth():
    return np.r_[EX, EY, YAW_RAD]


def _intrinsics_off(d):
    """K (3, 3) and dist (5,) moved by d (8,) in MAP_INTRINSICS' order."""
    return K + np.array([[d[0], 0, d[2]], [0, d[1], d[3]], [0, 0, 0]]), DIST + np.r_[d[4:8], 0.0]


def test_maps_recover_the_injected_errors_and_yaw_within_their_std():
    """With the true intrinsics (their covariance negligible), the maps and the yaw over 30 noise
    draws: errors over the std within 5 and of RMS 1 (13 values a seed, some 300 in all, their
    RMS 1 +- 0.05 if independent; 0.75-1.3 allows for their correlation within a seed). The
    yaw on its own too (pooled, a yaw std 10 x too large moves the RMS by 4 % only): 30
    independent z, whose RMS is 1 +- 1/sqrt(60) = 0.13; 0.6-1.5 is 3-4 of those either side."""
    z = []
    for seed in range(30):
        cmd, corners = _stations(np.random.default_rng(seed))
        m = measure_maps(BOARD, corners, K, DIST, cmd, 0)
        std = propagated_std(m, BOARD, K, DIST, cmd, 0, MAP_INTRINSICS, COV_INTR * 1e-12)
        z.append((m.vector() - _truth()) / std)
        if seed == 0:
            # a station's centroid scatters by the noise at 0.6 mm/px, averaged over the corners
            sigma_mm = NOISE_PX * 900 / 1500 / np.sqrt(len(BOARD))
            assert 0.5 * sigma_mm < m.fit_x.rmse < 2 * sigma_mm
            # the paper's camera-centre travel assumes the board square: its X map's y slope
            # takes the yaw
            assert abs(m.paper_fit_x.coef[2] - EX[2] + YAW_RAD) < 5 * m.paper_fit_x.std[2]
    z = np.array(z)
    assert np.all(np.abs(z) < 5), np.abs(z).max(axis=0)
    assert 0.75 < np.sqrt(np.mean(z**2)) < 1.3
    assert 0.6 < np.sqrt(np.mean(z[:, 12] ** 2)) < 1.5, z[:, 12]


def test_propagated_std_carries_the_intrinsics_covariance():
    """The maps measured from the same corners with intrinsics drawn from their covariance
    scatter by what propagated_std adds to the maps' own std: 400 draws give each coefficient's
    scatter to 1/sqrt(800) = 3.5 %; within 15 % is four of those."""
    cmd, corners = _stations(np.random.default_rng(7))
    m = measure_maps(BOARD, corners, K, DIST, cmd, 0)
    full = propagated_std(m, BOARD, K, DIST, cmd, 0, MAP_INTRINSICS, COV_INTR)
    own = propagated_std(m, BOARD, K, DIST, cmd, 0, MAP_INTRINSICS, COV_INTR * 1e-12)
    common = np.sqrt(full**2 - own**2)
    rng = np.random.default_rng(1)
    maps = [
        measure_maps(BOARD, corners, *_intrinsics_off(d), cmd, 0).vector()
        for d in rng.multivariate_normal(np.zeros(8), COV_INTR, 400)
    ]
    np.testing.assert_allclose(np.std(maps, axis=0, ddof=1) / common, 1.0, atol=0.15)
    # the intrinsics matter here: the X map's x slope moves by more than its own std
    assert common[1] > own[1]
