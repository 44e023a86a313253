"""Offscreen rendering through a lens: an ideal padded pinhole render, then the distortion.

One ``LensRenderer`` per process (a GL context does not survive ``fork``: use spawn pools).
"""

from __future__ import annotations

import cv2
import mujoco
import numpy as np

from calibench.scenes.camera import PIXEL_PITCH_M, PinholeCamera


class LensRenderer:
    """Renders a MuJoCo camera as seen through ``lens`` (intrinsics and distortion).

    The MJCF camera carries the lens's exact pinhole intrinsics; for the render its sensor is
    widened by a border so that every distorted pixel samples inside the ideal image.
    """

    def __init__(
        self, model: mujoco.MjModel, camera: str, lens: PinholeCamera, supersample: int = 1
    ):
        self.model = model
        self.camera_id = model.camera(camera).id
        self.lens = lens
        self.pad = lens.padding_px()
        self.supersample = supersample
        w, h = lens.width + 2 * self.pad, lens.height + 2 * self.pad
        self._size = (w, h)
        # Rendering k times larger on the same sensor scales fx and cx + 0.5 by k: an area
        # average of k x k blocks then returns exactly this camera's pixels, anti-aliased.
        ws, hs = w * supersample, h * supersample
        if ws > model.vis.global_.offwidth or hs > model.vis.global_.offheight:
            raise ValueError(f"offscreen buffer too small for a {ws}x{hs} render")
        self._renderer = mujoco.Renderer(model, hs, ws)
        map_x, map_y = lens.distortion_maps(self.pad)
        self._coords = np.stack([map_y, map_x]).astype(np.float64)
        self._remap = bilinear_matrix(self._coords, (h, w))
        self._padded_sensor = np.array([w, h], float) * PIXEL_PITCH_M
        self.option = mujoco.MjvOption()

    def show_groups(self, groups: dict[int, bool]) -> None:
        """Show or hide MuJoCo geom groups in the renders, {group: visible}."""
        for g, on in groups.items():
            self.option.geomgroup[g] = int(on)

    def render(
        self,
        data: mujoco.MjData,
        rng: np.random.Generator | None = None,
        noise_dn: float = 0.0,
        psf_px: float = 0.0,
    ) -> np.ndarray:
        """Distorted RGB image, shape (height, width, 3), uint8.

        ``psf_px`` blurs with the optics' point-spread function (Gaussian, 1-sigma in pixels);
        ``noise_dn`` then adds the sensor's noise (Gaussian, 1-sigma in grey levels, drawn from
        ``rng``) before quantisation.
        """
        sensor = self.model.cam_sensorsize[self.camera_id].copy()
        self.model.cam_sensorsize[self.camera_id] = self._padded_sensor
        try:
            self._renderer.update_scene(data, camera=self.camera_id, scene_option=self.option)
            ideal = self._renderer.render()
        finally:
            self.model.cam_sensorsize[self.camera_id] = sensor
        if self.supersample > 1:
            ideal = cv2.resize(ideal, self._size, interpolation=cv2.INTER_AREA)
        if not self.lens.dist.any():
            p = self.pad
            img = ideal[p : p + self.lens.height, p : p + self.lens.width].astype(np.float32)
        else:
            # Float bilinear sampling (cv2.remap quantises positions to 1/32 px) as one sparse
            # product: map_coordinates' order-1 sums, weights computed once per camera
            img = (self._remap @ ideal.reshape(-1, 3).astype(np.float64)).astype(np.float32)
            img = img.reshape(self.lens.height, self.lens.width, 3)
        if psf_px > 0:
            img = cv2.GaussianBlur(img, (0, 0), psf_px)
        if noise_dn > 0:
            if rng is None:
                raise ValueError("sensor noise needs a random generator")
            # one noise field for the three channels: a monochrome sensor seen as RGB
            img = img + rng.normal(0.0, noise_dn, img.shape[:2])[..., None].astype(np.float32)
        return np.clip(np.rint(img), 0, 255).astype(np.uint8)

    def close(self) -> None:
        """Free the GL context."""
        self._renderer.close()


def bilinear_matrix(coords: np.ndarray, shape: tuple[int, int]):
    """The sparse (n_out, H W) matrix of bilinear sampling at ``coords`` (2, h, w) (row, column)
    in an image of ``shape`` (H, W), edges extended (``map_coordinates(order=1, mode="nearest")``).
    """
    from scipy import sparse

    H, W = shape
    r = np.clip(coords[0].ravel(), 0, H - 1)
    c = np.clip(coords[1].ravel(), 0, W - 1)
    r0 = np.minimum(np.floor(r).astype(np.int64), H - 1)
    c0 = np.minimum(np.floor(c).astype(np.int64), W - 1)
    fr, fc = r - r0, c - c0
    r1, c1 = np.minimum(r0 + 1, H - 1), np.minimum(c0 + 1, W - 1)
    n = len(r)
    rows = np.repeat(np.arange(n), 4)
    cols = np.stack([r0 * W + c0, r0 * W + c1, r1 * W + c0, r1 * W + c1], axis=1).ravel()
    vals = np.stack([(1 - fr) * (1 - fc), (1 - fr) * fc, fr * (1 - fc), fr * fc], axis=1).ravel()
    return sparse.csr_matrix((vals, (rows, cols)), shape=(n, H * W))
