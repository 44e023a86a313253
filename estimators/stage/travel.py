"""Stage travel from camera poses of a target carried by the stage.

The camera is fixed to the machine; the target rides the carriage. Stations are indexed by the
views; ``ref`` is the home station against which travel is measured. Travel is returned in the
machine's axis frame (X, Y), shape (n_stations, 2), in the target's unit (mm).
"""

from __future__ import annotations

import numpy as np


def camera_centres(R_board2cam: np.ndarray, t_board2cam: np.ndarray) -> np.ndarray:
    """Camera centre in the board frame, C = -R^T t, (n, 3, 3), (n, 3) -> (n, 3)."""
    return -np.einsum("nji,nj->ni", R_board2cam, t_board2cam)


def travel_from_camera_centres(
    R_board2cam: np.ndarray, t_board2cam: np.ndarray, ref: int, board_xy_to_axes: np.ndarray
) -> np.ndarray:
    """The seed paper's travel: the difference of camera-centre positions in the board frame.

    The board moving by d moves the camera centre, seen from the board, by -d. The board is
    assumed square to the axes: ``board_xy_to_axes`` (2, 2) is the nominal mapping of board
    x, y onto machine X, Y (e.g. diag(1, -1) when the board's y runs along -Y).
    """
    C = camera_centres(R_board2cam, t_board2cam)
    return -(C[:, :2] - C[ref, :2]) @ np.asarray(board_xy_to_axes).T


def machine_axes_on_plane(
    normal: np.ndarray, x_axis_cam: np.ndarray, y_axis_cam: np.ndarray
) -> np.ndarray:
    """Unit machine X and Y directions in the camera frame, projected onto a plane.

    ``x_axis_cam``, ``y_axis_cam`` (3,) are the nominal directions of the machine axes as seen
    by the camera (its mount). Returns (2, 3), rows X then Y, orthonormal, in the plane.
    """
    n = np.asarray(normal, float)
    X = np.asarray(x_axis_cam, float) - n * (n @ x_axis_cam)
    X /= np.linalg.norm(X)
    Y = np.asarray(y_axis_cam, float) - n * (n @ y_axis_cam)
    Y -= X * (X @ Y)
    Y /= np.linalg.norm(Y)
    return np.stack([X, Y])


def travel_in_plane(
    points_cam: np.ndarray,
    ref: int,
    normal: np.ndarray,
    x_axis_cam: np.ndarray,
    y_axis_cam: np.ndarray,
) -> np.ndarray:
    """Travel of a point carried by the stage, from its positions (n, 3) in the camera frame.

    The differences from station ``ref`` are resolved on the machine axes projected onto the
    plane of motion (unit ``normal``).
    """
    axes = machine_axes_on_plane(normal, x_axis_cam, y_axis_cam)
    return (points_cam - points_cam[ref]) @ axes.T


def board_yaw(
    R_board2cam: np.ndarray,
    normal: np.ndarray,
    x_axis_cam: np.ndarray,
    y_axis_cam: np.ndarray,
    board_xy_to_axes: np.ndarray,
) -> float | np.ndarray:
    """Angle (rad) of the board's nominal X direction from the machine X axis, about +Z.

    +Z = X cross Y of the machine. Zero when the board sits as ``board_xy_to_axes`` says.
    ``R_board2cam`` (3, 3) gives a float; (n, 3, 3), one angle per pose (n,).
    """
    axes = machine_axes_on_plane(normal, x_axis_cam, y_axis_cam)
    # direction of the board's nominal X in the camera frame
    R = np.asarray(R_board2cam, float)
    bx = R[..., :, :2] @ np.linalg.solve(board_xy_to_axes, [1.0, 0.0])
    c, s = np.moveaxis(bx @ axes.T, -1, 0)
    yaw = np.arctan2(s, c)
    return float(yaw) if R.ndim == 2 else yaw
