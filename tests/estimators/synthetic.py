"""Synthetic data from a known truth, independent of MuJoCo and of the estimators."""

import cv2
import numpy as np

from calibench.scenes.checkerboard import Chessboard


def area_sample(
    K: np.ndarray, R: np.ndarray, t: np.ndarray, shade, size, supersample: int
) -> np.ndarray:
    """Float image of a plane at pose (R, t) through an ideal pinhole: each pixel averages
    supersample^2 samples mapped back onto the plane by the inverse homography, where
    ``shade(X, Y)`` gives the grey level (exact area sampling up to the supersampling)."""
    W, Hh = size
    Hi = np.linalg.inv(K @ np.c_[R[:, 0], R[:, 1], t])
    off = (np.arange(supersample) + 0.5) / supersample - 0.5
    v, u = np.mgrid[0:Hh, 0:W].astype(float)
    acc = np.zeros((Hh, W))
    for dv in off:
        for du in off:
            p = np.stack([u + du, v + dv, np.ones_like(u)], -1) @ Hi.T
            acc += shade(p[..., 0] / p[..., 2], p[..., 1] / p[..., 2])
    return acc / supersample**2


def raster_chessboard(
    board: Chessboard,
    K: np.ndarray,
    R: np.ndarray,
    t: np.ndarray,
    size=(640, 480),
    supersample: int = 8,
    background: float = 90.0,
) -> np.ndarray:
    """uint8 image of a board at pose (R, t) (board2cam, mm)."""
    sq, m = board.square_mm, board.margin_mm

    def shade(X, Y):
        a, b = np.floor(X / sq) + 1, np.floor(Y / sq) + 1
        squares = (a >= 0) & (a <= board.cols) & (b >= 0) & (b <= board.rows)
        plate = (
            (X >= -sq - m)
            & (X <= board.cols * sq + m)
            & (Y >= -sq - m)
            & (Y <= board.rows * sq + m)
        )
        return np.where(squares & ((a + b) % 2 == 0), 0.0, np.where(plate, 255.0, background))

    return np.clip(np.rint(area_sample(K, R, t, shade, size, supersample)), 0, 255).astype(np.uint8)


def project(board_pts, K, R, t, dist=None):
    rvec = cv2.Rodrigues(R)[0]
    p, _ = cv2.projectPoints(
        np.asarray(board_pts, float),
        rvec,
        np.asarray(t, float),
        K,
        np.zeros(5) if dist is None else dist,
    )
    return p.reshape(-1, 2)


def random_views(
    rng, board_pts, K, n_views, size=(640, 480), depth=(500.0, 900.0), tilt=0.5, dist=None
):
    """Poses whose corners all land inside the image; returns [(R, t)], [(n, 2) pixels]."""
    poses, pix = [], []
    centre = board_pts.mean(axis=0)
    while len(poses) < n_views:
        R = cv2.Rodrigues(np.r_[rng.uniform(-tilt, tilt, 2), rng.uniform(-0.3, 0.3)])[0]
        z = rng.uniform(*depth)
        c = np.array([rng.uniform(-0.3, 0.3) * z, rng.uniform(-0.2, 0.2) * z, z])
        t = c - R @ centre
        p = project(board_pts, K, R, t, dist)
        if (p > 5).all() and (p < np.array(size) - 5).all():
            poses.append((R, t))
            pix.append(p)
    return poses, pix


def raster_disc(
    K: np.ndarray,
    R: np.ndarray,
    t: np.ndarray,
    radius: float,
    size=(768, 576),
    supersample: int = 4,
    dark: float = 20.0,
    bright: float = 230.0,
) -> np.ndarray:
    """Float image of a dark disc of ``radius`` centred at the origin of the plane (R, t)."""
    return area_sample(
        K,
        R,
        t,
        lambda X, Y: np.where(X * X + Y * Y <= radius * radius, dark, bright),
        size,
        supersample,
    )


def rotation(w):
    """The rotation matrix (3, 3) of the rotation vector ``w`` (3,) rad, by Rodrigues' formula."""
    th = np.linalg.norm(w)
    k = w / th
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(th) * K + (1 - np.cos(th)) * K @ K


def hexapod():
    """A 6-6 Stewart platform's nominal platform and base hinges r, B (6, 3) mm, paired 30 deg
    apart on radii of 300 and 500 mm."""
    a = np.deg2rad([-15, 15, 105, 135, 225, 255])
    B = np.c_[500 * np.cos(a), 500 * np.sin(a), np.zeros(6)]
    b = np.deg2rad([-45, 45, 75, 165, 195, 285])
    r = np.c_[300 * np.cos(b), 300 * np.sin(b), np.zeros(6)]
    return r, B
