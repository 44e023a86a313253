"""A camera as built: exact pinhole intrinsics for the MJCF, Brown-Conrady lens distortion.

Frames. MuJoCo's camera frame looks along -z with y up; calibench's camera frame is OpenCV's:
x right, y down, z forward (``cv = diag(1, -1, -1) @ mj``). Pixels use OpenCV's convention:
the centre of the top-left pixel is (0, 0).

The renderer is an ideal pinhole; the lens is applied to the rendered image with ``cv2.remap``
through the exact inverse of the distortion model (Newton iterations, not OpenCV's).
"""

from __future__ import annotations

import dataclasses

import numpy as np

MJ_TO_CV = np.diag([1.0, -1.0, -1.0])
PIXEL_PITCH_M = 1e-5  # arbitrary: only focal / sensorsize ratios matter to MuJoCo


@dataclasses.dataclass(frozen=True)
class PinholeCamera:
    """Intrinsics in pixels and distortion coefficients in OpenCV's order.

    Defaults: the belt-stage seed paper's camera (Eq. 19) with a mild barrel lens.
    """

    width: int = 640
    height: int = 480
    fx: float = 562.45
    fy: float = 569.96
    cx: float = 319.05
    cy: float = 239.31
    k1: float = -0.12
    k2: float = 0.08
    p1: float = 4e-4
    p2: float = -3e-4
    k3: float = 0.0

    @property
    def K(self) -> np.ndarray:
        """The intrinsic matrix, (3, 3) px (OpenCV's convention)."""
        return np.array([[self.fx, 0, self.cx], [0, self.fy, self.cy], [0, 0, 1.0]])

    @property
    def dist(self) -> np.ndarray:
        """(k1, k2, p1, p2, k3), shape (5,)."""
        return np.array([self.k1, self.k2, self.p1, self.p2, self.k3])

    def mjcf_attributes(
        self, width: int | None = None, height: int | None = None
    ) -> dict[str, str]:
        """``<camera>`` attributes that give these intrinsics for a render of width x height.

        A larger render (padding) keeps fx, fy and the principal point's offset from the
        image centre's pixel, so the padded image is this camera's image with a border.
        """
        w = self.width if width is None else width
        h = self.height if height is None else height
        px, py = (w - self.width) / 2, (h - self.height) / 2
        if px % 1 or py % 1:
            raise ValueError("padding must be a whole number of pixels on each side")
        cx, cy = self.cx + px, self.cy + py
        s = PIXEL_PITCH_M
        # MuJoCo >= 3.6: cx = W/2 - 0.5 - p_x/s_x*W (pinned and checked by a regression test).
        principal_x = (w / 2 - 0.5 - cx) * s
        principal_y = (h / 2 - 0.5 - cy) * s
        return {
            "sensorsize": f"{w * s:.12g} {h * s:.12g}",
            "focal": f"{self.fx * s:.12g} {self.fy * s:.12g}",
            "principal": f"{principal_x:.12g} {principal_y:.12g}",
            "resolution": f"{w} {h}",
        }

    # --- the lens -------------------------------------------------------------------------
    def distort_normalized(self, xy: np.ndarray) -> np.ndarray:
        """Ideal normalised coordinates to distorted ones, shape (n, 2) -> (n, 2)."""
        x, y = xy[..., 0], xy[..., 1]
        r2 = x * x + y * y
        radial = 1 + r2 * (self.k1 + r2 * (self.k2 + r2 * self.k3))
        xd = x * radial + 2 * self.p1 * x * y + self.p2 * (r2 + 2 * x * x)
        yd = y * radial + self.p1 * (r2 + 2 * y * y) + 2 * self.p2 * x * y
        return np.stack([xd, yd], axis=-1)

    def undistort_normalized(self, xy_d: np.ndarray, iterations: int = 20) -> np.ndarray:
        """Exact inverse of :meth:`distort_normalized` by Newton's method, shape (n, 2)."""
        xy = np.array(xy_d, dtype=float)
        eps = 1e-7
        for _ in range(iterations):
            f = self.distort_normalized(xy) - xy_d
            # 2x2 Jacobian by central differences: cheap, exact enough for a contraction.
            jx = (
                self.distort_normalized(xy + [eps, 0]) - self.distort_normalized(xy - [eps, 0])
            ) / (2 * eps)
            jy = (
                self.distort_normalized(xy + [0, eps]) - self.distort_normalized(xy - [0, eps])
            ) / (2 * eps)
            det = jx[..., 0] * jy[..., 1] - jy[..., 0] * jx[..., 1]
            dx = (jy[..., 1] * f[..., 0] - jy[..., 0] * f[..., 1]) / det
            dy = (-jx[..., 1] * f[..., 0] + jx[..., 0] * f[..., 1]) / det
            xy[..., 0] -= dx
            xy[..., 1] -= dy
            if np.max(np.abs(f)) < 1e-14:
                break
        return xy

    def project(self, points_cam: np.ndarray, distort: bool = True) -> np.ndarray:
        """Points in the (OpenCV) camera frame to pixels, shape (n, 3) -> (n, 2)."""
        xy = points_cam[:, :2] / points_cam[:, 2:3]
        if distort:
            xy = self.distort_normalized(xy)
        return np.stack([self.fx * xy[:, 0] + self.cx, self.fy * xy[:, 1] + self.cy], axis=1)

    def padding_px(self) -> int:
        """Border an ideal render needs so that every distorted pixel samples inside it."""
        u = np.r_[
            np.linspace(0, self.width - 1, 64),
            np.full(64, self.width - 1),
            np.linspace(0, self.width - 1, 64),
            np.zeros(64),
        ]
        v = np.r_[
            np.zeros(64),
            np.linspace(0, self.height - 1, 64),
            np.full(64, self.height - 1),
            np.linspace(0, self.height - 1, 64),
        ]
        ideal = self._ideal_pixels(u, v)
        over = max(
            0.0,
            -ideal[:, 0].min(),
            ideal[:, 0].max() - (self.width - 1),
            -ideal[:, 1].min(),
            ideal[:, 1].max() - (self.height - 1),
        )
        return int(np.ceil(over)) + 4

    def _ideal_pixels(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        xy_d = np.stack([(u - self.cx) / self.fx, (v - self.cy) / self.fy], axis=-1)
        xy = self.undistort_normalized(xy_d)
        return np.stack([self.fx * xy[..., 0] + self.cx, self.fy * xy[..., 1] + self.cy], axis=-1)

    def distortion_maps(self, pad: int) -> tuple[np.ndarray, np.ndarray]:
        """``cv2.remap`` maps from an ideal render padded by ``pad`` px to the lens image.

        Returns map_x, map_y of shape (height, width), float32.
        """
        v, u = np.mgrid[0 : self.height, 0 : self.width].astype(float)
        ideal = self._ideal_pixels(u, v) + pad
        return ideal[..., 0].astype(np.float32), ideal[..., 1].astype(np.float32)


def world_to_cv_camera(
    points_world: np.ndarray, cam_pos: np.ndarray, cam_xmat: np.ndarray
) -> np.ndarray:
    """World points to the OpenCV camera frame of a MuJoCo camera, shape (n, 3) -> (n, 3).

    ``cam_xmat`` is MuJoCo's camera orientation (columns = camera axes in world), (3, 3).
    Several cameras at once: points (k, n, 3), cam_pos (k, 1, 3), cam_xmat (k, 3, 3).
    """
    return (points_world - cam_pos) @ cam_xmat @ MJ_TO_CV
