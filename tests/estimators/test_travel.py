"""Travel from board poses: exact on noiseless poses, the paper's form and ours."""

import cv2
import numpy as np

from calibench.estimators.stage.travel import board_yaw, travel_from_camera_centres, travel_in_plane

# camera looking down: image x along machine X, image y along -Y; board x along X, y along -Y
X_CAM, Y_CAM = np.array([1.0, 0, 0]), np.array([0, -1.0, 0])
BOARD_TO_AXES = np.diag([1.0, -1.0])


def _stations(yaw, tilt=0.0):
    """board2cam poses for a board yawed by ``yaw`` (about +Z = toward the camera) moving by d."""
    d = np.array([[0, 0], [100, 0], [0, 250], [730, 410]], float)
    Rz = cv2.Rodrigues(np.array([0, 0, -yaw]))[0]  # +Z is -z of the camera
    R = cv2.Rodrigues(np.array([tilt, 0, 0]))[0] @ Rz
    n = R[:, 2]
    axes = np.stack([X_CAM - n * (n @ X_CAM), Y_CAM - n * (n @ Y_CAM)])
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    t0 = np.array([-300.0, 200.0, 1800.0])
    t = t0 + d @ axes
    return np.repeat(R[None], len(d), axis=0), t, d


def test_travel_in_plane_and_yaw_are_exact():
    R, t, d = _stations(yaw=4e-3)
    np.testing.assert_allclose(travel_in_plane(t, 0, R[0][:, 2], X_CAM, Y_CAM), d, atol=1e-9)
    assert abs(board_yaw(R[0], R[0][:, 2], X_CAM, Y_CAM, BOARD_TO_AXES) - 4e-3) < 1e-12
    np.testing.assert_allclose(
        board_yaw(R, R[0][:, 2], X_CAM, Y_CAM, BOARD_TO_AXES), 4e-3, atol=1e-12
    )  # per pose


def test_paper_travel_exact_when_board_is_square_and_wrong_by_the_yaw_otherwise():
    R, t, d = _stations(yaw=0.0)
    np.testing.assert_allclose(travel_from_camera_centres(R, t, 0, BOARD_TO_AXES), d, atol=1e-9)
    R, t, d = _stations(yaw=4e-3)
    err = travel_from_camera_centres(R, t, 0, BOARD_TO_AXES) - d
    # assuming the board square to the axes turns the travel by the yaw: |R d - d| = 2 sin(yaw/2)|d|
    np.testing.assert_allclose(
        np.linalg.norm(err, axis=1),
        2 * np.sin(2e-3) * np.linalg.norm(d, axis=1),
        rtol=1e-6,
        atol=1e-9,
    )
