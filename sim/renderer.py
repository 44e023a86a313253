"""Offscreen rendering through a lens: an ideal padded pinhole render, then the distortion.

One ``LensRenderer`` per process (a GL context does not survive ``fork``: use spawn pools).
"""

from __future__ import annotations

import dataclasses
import functools
from concurrent.futures import Future, ThreadPoolExecutor
from typing import TYPE_CHECKING

import cv2
import mujoco
import numpy as np

from calibench.scenes.camera import PIXEL_PITCH_M, PinholeCamera
from calibench.sim.offscreen import Offscreen

if TYPE_CHECKING:
    from scipy import sparse

# A frame's noise is drawn on its own thread from this size on (a quarter VGA: about 1.5 ms of
# draws on 2 slow cores); a smaller window's is drawn in turn.
NOISE_THREAD_MIN_PX = 320 * 240


class LensSampling:
    """Where each pixel of a lens's image samples the ideal render padded by ``pad`` px.

    Parameters
    ----------
    lens : PinholeCamera
        The lens (intrinsics and distortion).
    pad : int
        The ideal render's border, px.

    Attributes
    ----------
    shape : tuple of int
        The padded ideal image's (height, width), px.
    coords : ndarray, (2, height, width)
        Each pixel's sample (row, column) in the padded ideal image, float64.
    cells : ndarray, (2, height, width)
        Its cell: the sample clipped into the image, floored, int32.
    weights : ndarray, (2, height, width)
        The bilinear weights within the cell (the fractions of row and column), float32.
    """

    def __init__(self, lens: PinholeCamera, pad: int):
        self.shape = (lens.height + 2 * pad, lens.width + 2 * pad)
        map_x, map_y = lens.distortion_maps(pad)
        self.coords = np.stack([map_y, map_x]).astype(np.float64)
        h, w = self.shape
        inside = np.clip(self.coords, 0, np.array([h - 1, w - 1], float)[:, None, None])
        cells = np.floor(inside)
        self.cells = cells.astype(np.int32)
        self.weights = (inside - cells).astype(np.float32)
        for a in (self.coords, self.cells, self.weights):
            a.flags.writeable = False  # shared by every renderer of the lens
        self._remap = None

    def remap(self) -> sparse.csr_matrix:
        """The full frame's sampling as one sparse matrix, (height x width, H x W) of the padded
        ideal image's H x W pixels (made on first use: a study reads out areas of interest
        only, and the matrix is 16-23 MB)."""
        if self._remap is None:
            self._remap = bilinear_matrix(self.coords, self.shape)
        return self._remap


@functools.lru_cache(maxsize=4)
def lens_sampling(lens: PinholeCamera, pad: int) -> LensSampling:
    """The lens's :class:`LensSampling`, made once per process: a study's trials render through
    the same lens, and its maps were a tenth of a rendered belt-stage trial.

    Parameters
    ----------
    lens : PinholeCamera
        The lens (a frozen dataclass: its values are the key).
    pad : int
        The ideal render's border, px.

    Returns
    -------
    LensSampling
        Shared and read-only.
    """
    return LensSampling(lens, pad)


@dataclasses.dataclass(frozen=True)
class Exposure:
    """One frame as the GL context gave it, its sensor noise drawn: what
    :meth:`LensRenderer.develop` makes the image of, on any thread.

    Attributes
    ----------
    ideal : ndarray, (H, W, 3) uint8
        The ideal (distortion-free) render, supersampled: of the whole padded sensor, or of the
        block of it that ``window`` samples.
    window : tuple of int or None
        The area of interest (u0, v0, u1, v1) px, half-open; None for the whole image.
    block : tuple of int or None
        Where ``ideal`` lies in the padded ideal image: (row, column) of its first pixel.
    noise : ndarray, (h, w) float32, or None
        The sensor's noise (grey levels) over the image, drawn in the frames' order.
    psf_px : float
        The optics' blur, 1-sigma px.
    """

    ideal: np.ndarray
    window: tuple[int, int, int, int] | None
    block: tuple[int, int] | None
    noise: np.ndarray | None
    psf_px: float


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
        # MSAA resolves geometry's edges only: the boards are textures, filtered per pixel, and
        # their corners came out identical with and without it, at twice the render's cost
        model.vis.quality.offsamples = 0
        self._offscreen = Offscreen(model)
        self.gl_renderer = self._offscreen.renderer  # what rasterises: a GPU, or llvmpipe (CPU)
        # each sensor pixel's sample in the ideal image: the same for every renderer of this lens
        self._sampling = lens_sampling(lens, self.pad)
        self._padded_sensor = np.array([w, h], float) * PIXEL_PITCH_M
        self.option = mujoco.MjvOption()
        # the thread that draws a frame's noise while GL renders it (GL lets go of the GIL)
        self._noise_thread: ThreadPoolExecutor | None = None

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
        window: tuple[int, int, int, int] | None = None,
    ) -> np.ndarray:
        """Distorted RGB image, shape (height, width, 3), uint8.

        ``psf_px`` blurs with the optics' point-spread function (Gaussian, 1-sigma in pixels);
        ``noise_dn`` then adds the sensor's noise (Gaussian, 1-sigma in grey levels, drawn from
        ``rng``) before quantisation. ``window`` (u0, v0, u1, v1) px, half-open, reads out that
        area of the sensor only, as a machine-vision camera's area of interest does: the image
        is then (v1 - v0, u1 - u0, 3), and only the part of the ideal image it needs is rendered.
        :meth:`capture` then :meth:`develop`.
        """
        return self.develop(self.capture(data, rng, noise_dn, psf_px, window))

    def capture(
        self,
        data: mujoco.MjData,
        rng: np.random.Generator | None = None,
        noise_dn: float = 0.0,
        psf_px: float = 0.0,
        window: tuple[int, int, int, int] | None = None,
    ) -> Exposure:
        """What needs the GL context (this renderer's thread) and the generator: the ideal
        render and the sensor's noise, drawn now so that frames developed out of order, on other
        threads, have the noise they would have had in order. The arguments: :meth:`render`'s."""
        if noise_dn > 0 and rng is None:
            raise ValueError("sensor noise needs a random generator")
        if window is None:
            shape = (self.lens.height, self.lens.width)
        else:
            u0, v0, u1, v1 = (int(x) for x in window)
            if not (0 <= u0 < u1 <= self.lens.width and 0 <= v0 < v1 <= self.lens.height):
                raise ValueError(
                    f"window {window} outside the {self.lens.width}x{self.lens.height} image"
                )
            shape = (v1 - v0, u1 - u0)
        # The noise is drawn while GL renders (the same draws from the same generator as in
        # turn: nothing else draws from it until this frame is captured); a small window's is
        # drawn in turn, in less time than a hand-over to the thread takes.
        drawing: Future | None = None
        if noise_dn > 0 and shape[0] * shape[1] >= NOISE_THREAD_MIN_PX:
            drawing = self._drawer().submit(sensor_noise, rng, shape, noise_dn)
        try:
            if window is None:
                ideal, block = self._render_full(data), None
                if self.lens.dist.any():
                    self._sampling.remap()  # made here, once, not by two developing threads
            else:
                ideal, block = self._render_window(data, window)
        except BaseException:
            # never raise while the thread still draws from the caller's generator; the render's
            # error is the one to say, not the draw's
            if drawing is not None:
                drawing.exception()
            raise
        noise = drawing.result() if drawing is not None else None
        if noise is None and noise_dn > 0:
            noise = sensor_noise(rng, shape, noise_dn)
        return Exposure(ideal, window, block, noise, psf_px)

    def _drawer(self) -> ThreadPoolExecutor:
        """The noise's thread, started with the first full frame."""
        if self._noise_thread is None:
            self._noise_thread = ThreadPoolExecutor(1, thread_name_prefix="sensor-noise")
        return self._noise_thread

    def develop(self, exposure: Exposure) -> np.ndarray:
        """The image (h, w, 3) uint8 of a captured frame: the supersampled render averaged down,
        the lens's distortion, the optics' blur, the sensor's noise and its quantisation. Reads
        only what every frame shares (read-only), so frames may be developed on any thread."""
        ideal = exposure.ideal
        if self.supersample > 1:
            h, w = ideal.shape[0] // self.supersample, ideal.shape[1] // self.supersample
            ideal = cv2.resize(ideal, (w, h), interpolation=cv2.INTER_AREA)
        if exposure.window is None:
            img = self._through_lens(ideal)
        else:
            assert exposure.block is not None
            img = self._window_through_lens(ideal, exposure.window, exposure.block)
        return _sensor(img, exposure.noise, exposure.psf_px)

    def _render_full(self, data) -> np.ndarray:
        """The whole padded sensor's ideal render, supersampled."""
        sensor = self.model.cam_sensorsize[self.camera_id].copy()
        self.model.cam_sensorsize[self.camera_id] = self._padded_sensor
        try:
            k = self.supersample
            return self._offscreen.render(
                data, self.camera_id, self.option, self._size[0] * k, self._size[1] * k
            )
        finally:
            self.model.cam_sensorsize[self.camera_id] = sensor

    def _through_lens(self, ideal: np.ndarray) -> np.ndarray:
        """The whole image, float32 (h, w, 3) or (h, w), from the padded ideal one."""
        if not self.lens.dist.any():
            p = self.pad
            return ideal[p : p + self.lens.height, p : p + self.lens.width].astype(np.float32)
        # Float bilinear sampling (cv2.remap quantises positions to 1/32 px) as one sparse
        # product: map_coordinates' order-1 sums, weights computed once per lens
        remap = self._sampling.remap()
        shape = (self.lens.height, self.lens.width)
        if _is_grey(ideal):  # one channel through the lens: the same pixels, a third the work
            img = (remap @ ideal[..., 0].ravel().astype(np.float64)).astype(np.float32)
            return img.reshape(shape)
        img = (remap @ ideal.reshape(-1, 3).astype(np.float64)).astype(np.float32)
        return img.reshape(shape + (3,))

    def _window_cells(self, window):
        """The window's pixels' cells in the padded ideal image: rows and columns (h, w) int32."""
        u0, v0, u1, v1 = window
        cells = self._sampling.cells
        return cells[0][v0:v1, u0:u1], cells[1][v0:v1, u0:u1]

    def _render_window(self, data, window) -> tuple[np.ndarray, tuple[int, int]]:
        """:meth:`capture`'s area of interest: the ideal image rendered over the block of the
        padded sensor that the window's distorted pixels sample, with the camera's principal
        point moved so that this block is exactly that part of the full render. Returns the
        block (supersampled) and its first pixel's (row, column)."""
        u0, v0, u1, v1 = (int(x) for x in window)
        if not (0 <= u0 < u1 <= self.lens.width and 0 <= v0 < v1 <= self.lens.height):
            raise ValueError(
                f"window {window} outside the {self.lens.width}x{self.lens.height} image"
            )
        rows, cols = self._window_cells((u0, v0, u1, v1))
        W, H = self._size
        p = self.pad
        if self.lens.dist.any():
            (r_lo, r_hi), (c_lo, c_hi) = (rows.min(), rows.max()), (cols.min(), cols.max())
        else:  # a pinhole's cells are the window's pixels shifted by the pad
            (r_lo, r_hi), (c_lo, c_hi) = (v0 + p, v1 - 1 + p), (u0 + p, u1 - 1 + p)
        # the block sampled (the bilinear neighbours and a pixel more), in 32 px steps
        r0 = max(int(r_lo) - 1, 0)
        c0 = max(int(c_lo) - 1, 0)
        hb = min(-(-(int(r_hi) + 3 - r0) // 32) * 32, H)
        wb = min(-(-(int(c_hi) + 3 - c0) // 32) * 32, W)
        r0, c0 = min(r0, H - hb), min(c0, W - wb)
        return self._render_block(data, r0, c0, wb, hb), (r0, c0)

    def _window_through_lens(self, ideal: np.ndarray, window, block) -> np.ndarray:
        """The window's image, float32 (h, w, 3) or (h, w), from the ideal block (hb, wb, 3)
        whose first pixel is ``block`` (row, column) of the padded ideal image."""
        u0, v0, u1, v1 = (int(x) for x in window)
        r0, c0 = block
        hb, wb = ideal.shape[:2]
        p = self.pad
        if not self.lens.dist.any():  # the pinhole's pixels: the block's, shifted by the pad
            crop = ideal[v0 + p - r0 : v1 + p - r0, u0 + p - c0 : u1 + p - c0]
            if _is_grey(crop):  # one channel through the sensor: the same pixels, a third the work
                crop = crop[..., 0]
            return crop.astype(np.float32)
        rows, cols = self._window_cells((u0, v0, u1, v1))
        weights = self._sampling.weights
        ri = np.minimum(rows - r0, hb - 1)
        ci = np.minimum(cols - c0, wb - 1)
        fr, fc = weights[0][v0:v1, u0:u1], weights[1][v0:v1, u0:u1]
        # the cell's four corners in the block's flat index (no right or lower neighbour on its
        # last column or row: the corner itself, weighted by zero there)
        i00 = ri * wb + ci
        i01 = i00 + (ci + 1 < wb)
        down = np.where(ri + 1 < hb, wb, 0)
        i10, i11 = i00 + down, i01 + down
        gc, gr = 1 - fc, 1 - fr
        # channel by channel: numpy's loops over a last axis of 3 run at a third of their speed;
        # a grey block's one channel only (the circle plate's)
        planes = [ideal[..., 0]] if _is_grey(ideal) else cv2.split(ideal)
        img = np.empty(fr.shape + (len(planes),), np.float32)
        for ch, plane in enumerate(planes):
            flat = plane.ravel()
            top = gc * flat[i00] + fc * flat[i01]
            low = gc * flat[i10] + fc * flat[i11]
            img[..., ch] = gr * top + fr * low
        return img[..., 0] if len(planes) == 1 else img

    def _render_block(self, data, r0: int, c0: int, wb: int, hb: int) -> np.ndarray:
        """The ideal padded render's block of rows r0:r0+hb, columns c0:c0+wb, supersampled:
        (k hb, k wb, 3)."""
        k = self.supersample
        cam = self.camera_id
        sensor = self.model.cam_sensorsize[cam].copy()
        intrinsic = self.model.cam_intrinsic[cam].copy()
        W, H = self._size
        # MuJoCo's principal point: c = W/2 - 0.5 - p/s (scenes/camera.py); the block's own c is
        # the padded image's less (c0, r0)
        cx = W / 2 - 0.5 - intrinsic[2] / PIXEL_PITCH_M
        cy = H / 2 - 0.5 - intrinsic[3] / PIXEL_PITCH_M
        try:
            self.model.cam_sensorsize[cam] = np.array([wb, hb], float) * PIXEL_PITCH_M
            self.model.cam_intrinsic[cam, 2] = (wb / 2 - 0.5 - (cx - c0)) * PIXEL_PITCH_M
            self.model.cam_intrinsic[cam, 3] = (hb / 2 - 0.5 - (cy - r0)) * PIXEL_PITCH_M
            block = self._offscreen.render(data, cam, self.option, wb * k, hb * k)
        finally:
            self.model.cam_sensorsize[cam] = sensor
            self.model.cam_intrinsic[cam] = intrinsic
        return block

    def close(self) -> None:
        """Free the GL context (and the noise's thread)."""
        self._offscreen.close()
        if self._noise_thread is not None:
            self._noise_thread.shutdown()
            self._noise_thread = None


def sensor_noise(
    rng: np.random.Generator | None, shape: tuple[int, int], noise_dn: float
) -> np.ndarray:
    """The sensor's noise (h, w) float32 grey levels: Gaussian, 1-sigma ``noise_dn``."""
    assert rng is not None
    return rng.standard_normal(shape, np.float32) * np.float32(noise_dn)


def _is_grey(img: np.ndarray) -> bool:
    """Whether an (h, w, 3) image's three channels are the same. A sparse grid of its pixels is
    compared first: a colour image (the belt's) is told apart without the whole comparison."""
    for a in (img[::16, ::16], img):
        if not (np.array_equal(a[..., 0], a[..., 1]) and np.array_equal(a[..., 0], a[..., 2])):
            return False
    return True


def _sensor(img: np.ndarray, noise: np.ndarray | None, psf_px: float) -> np.ndarray:
    """The optics' blur, the sensor's noise (h, w) float32 grey levels, and its quantisation of an
    image (h, w, 3) float32, or (h, w) of a grey one; returns (h, w, 3) uint8."""
    grey = img.ndim == 2 or _is_grey(img)
    if img.ndim == 3 and grey:  # a grey scene (the circle plate's): one channel's work
        img = np.ascontiguousarray(img[..., 0])
    if psf_px > 0:
        img = cv2.GaussianBlur(img, (0, 0), psf_px)
    if noise is not None:
        # one noise field for the three channels: a monochrome sensor seen as RGB; the colour
        # field's three planes made by OpenCV (numpy's broadcast over a last axis of 3 is three
        # times slower)
        img = img + (noise if grey else cv2.merge((noise, noise, noise)))
    out = np.clip(np.rint(img), 0, 255).astype(np.uint8)
    return cv2.cvtColor(out, cv2.COLOR_GRAY2RGB) if grey else out


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
