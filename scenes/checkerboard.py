"""A chessboard calibration plate: exact inner-corner coordinates and its texture image.

Board frame (OpenCV's): origin at the first inner corner, x along a row of inner corners, y
from row to row, z = x cross y pointing *into* the plate, so that seen from the front with x to
the right, y runs down. Lengths in mm. The corner order is OpenCV's (row-major, ``cols``
corners per row), and the square diagonally before corner 0 (towards -x, -y) is black, so a
detector can tell the board from its 180 degree turn when ``cols + rows`` is odd.
"""

from __future__ import annotations

import dataclasses
import functools

import cv2
import numpy as np

TEXTURE_PX_PER_SQUARE = (
    64  # the texture's resolution the scenes use: the margin a whole number of its pixels
)


@dataclasses.dataclass(frozen=True)
class Chessboard:
    """A printed chessboard with a white margin.

    Parameters
    ----------
    cols, rows : int
        Inner corners per row and per column.
    square_mm : float
        Side of one square.
    margin_mm : float
        White border around the outer squares (a quiet zone for the detector).
    """

    cols: int = 9
    rows: int = 6
    square_mm: float = 40.0
    margin_mm: float = 40.0

    @property
    def n_corners(self) -> int:
        """The number of inner corners, cols x rows."""
        return self.cols * self.rows

    @property
    def size_mm(self) -> tuple[float, float]:
        """Outer size of the plate (width along x, height along y), margins included."""
        return (
            (self.cols + 1) * self.square_mm + 2 * self.margin_mm,
            (self.rows + 1) * self.square_mm + 2 * self.margin_mm,
        )

    @property
    def origin_in_plate_mm(self) -> np.ndarray:
        """Board-frame origin (corner 0) measured from the plate's lower-left edge, shape (2,)."""
        return np.array([self.margin_mm + self.square_mm, self.margin_mm + self.square_mm])

    @property
    def centre_mm(self) -> np.ndarray:
        """Centre of the plate in the board frame, shape (2,)."""
        return np.array(
            [(self.cols - 1) * self.square_mm / 2, (self.rows - 1) * self.square_mm / 2]
        )

    def corners_mm(self) -> np.ndarray:
        """Inner corners in the board frame, shape (n_corners, 3), OpenCV order."""
        j, i = np.mgrid[0 : self.rows, 0 : self.cols]
        xy = np.stack([i.ravel(), j.ravel()], axis=1) * self.square_mm
        return np.hstack([xy, np.zeros((self.n_corners, 1))])

    def texture(self, px_per_square: int = TEXTURE_PX_PER_SQUARE) -> np.ndarray:
        """Texture image of the whole plate, shape (height_px, width_px, 3), uint8 RGB.

        Stored as the plate is seen from the front: row 0 is the plate edge at the smallest
        board y. Squares are whole texture pixels, so corners fall on pixel edges.
        """
        s = px_per_square
        m = self.margin_mm / self.square_mm * s
        if abs(m - round(m)) > 1e-9:
            raise ValueError("the margin must be a whole number of texture pixels")
        m = int(round(m))
        nx, ny = self.cols + 1, self.rows + 1
        # Square (a, b), a along x and b along y, is black when a + b is even: the square
        # before corner 0 is (0, 0).
        a = np.arange(nx * s) // s
        b = np.arange(ny * s) // s
        black = ((a[None, :] + b[:, None]) % 2) == 0
        img = np.full((ny * s + 2 * m, nx * s + 2 * m), 255, np.uint8)
        img[m : m + ny * s, m : m + nx * s][black] = 0
        return np.repeat(img[:, :, None], 3, axis=2)

    def texture_png(self, px_per_square: int = TEXTURE_PX_PER_SQUARE) -> bytes:
        """The board's texture as PNG bytes, ``px_per_square`` pixels a square (encoded once per
        board: a study builds thousands of twins of one board)."""
        return _texture_png(self, px_per_square)


@functools.lru_cache(maxsize=16)
def _texture_png(board: Chessboard, px_per_square: int) -> bytes:
    """:meth:`Chessboard.texture_png`, remembered (a frozen board: its PNG is a function of it)."""
    ok, buf = cv2.imencode(".png", board.texture(px_per_square))
    assert ok
    return buf.tobytes()
