"""How far a chessboard extends beyond the grid of inner corners a detector found.

OpenCV's detectors, asked for a ``cols`` x ``rows`` grid, also find one on a larger board (a
part of it, or a grid that steps over a line of it): a calibration would then run with another
board's corner coordinates, without a word. From the grid found, the next line of corners
beyond each of its four sides is predicted (a quadratic along each grid line: perspective and
distortion to second order), refined to the image's saddle points, and judged; so is the line
halfway between two neighbouring lines of the grid, which a grid that skipped one stepped over.
A line is the board's when every point of it is a chessboard corner, four squares alternating
dark and light around it with the contrast of the grid's own corners. Beyond a board's last
inner corners lie its outer squares and its margin, two of the four alike: no corner there.

Pixels in OpenCV's convention; corners in the detector's order, (rows * cols, 2), row-major.
"""

from __future__ import annotations

import numpy as np

from calibench.estimators.camera.chessboard import refine_saddle

# a corner's four squares are sampled at this fraction of a grid step from it along each grid
# direction: inside an outer square even where a board's edge squares are printed half-width
_REACH = 0.3
_PATCH = np.linspace(-0.1, 0.1, 3)  # the samples around each square's point, in grid steps
# a predicted point is a corner when its squares' contrast is at least this share of the grid's
# own corners' (median), and the two squares of each diagonal differ by at most this share of it
_CONTRAST, _ALIKE = 0.5, 0.35


def corner_likeness(
    gray: np.ndarray, points: np.ndarray, u: np.ndarray, v: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The four squares around each point: their contrast across the diagonals and the
    difference within a diagonal (a chessboard corner: large, and small).

    Parameters
    ----------
    gray : ndarray, shape (h, w)
        The image.
    points : ndarray, shape (n, 2)
        Where to judge, px.
    u, v : ndarray, shape (n, 2)
        The grid's steps at each point along its two directions, px.

    Returns
    -------
    contrast, alike : ndarray, shape (n,)
        |mean of one diagonal's squares - the other's| and the larger difference between the
        two squares of a diagonal, in the image's grey levels.
    """
    a, b = (x.ravel() for x in np.meshgrid(_PATCH, _PATCH))
    means = []
    for su, sv in ((1, 1), (-1, -1), (1, -1), (-1, 1)):
        at = (
            points[:, None, :]
            + (su * _REACH + a[None, :, None]) * u[:, None, :]
            + (sv * _REACH + b[None, :, None]) * v[:, None, :]
        )
        x = np.clip(np.rint(at[..., 0]).astype(np.intp), 0, gray.shape[1] - 1)
        y = np.clip(np.rint(at[..., 1]).astype(np.intp), 0, gray.shape[0] - 1)
        means.append(gray[y, x].astype(float).mean(axis=1))
    pp, mm, pm, mp = means
    contrast = np.abs((pp + mm) - (pm + mp)) / 2
    return contrast, np.maximum(np.abs(pp - mm), np.abs(pm - mp))


def extra_lines(
    gray: np.ndarray, corners: np.ndarray, cols: int, rows: int, most: int = 100
) -> tuple[int, int, int, int]:
    """Lines of inner corners the board shows beyond the grid found, on each of its sides.

    Parameters
    ----------
    gray : ndarray, shape (h, w)
        The image the grid was found in.
    corners : ndarray, shape (rows * cols, 2)
        The grid found, row-major (``cols`` per row), px.
    cols, rows : int
        The grid's size, inner corners (each at least 2).
    most : int
        Lines counted at most on a side.

    Returns
    -------
    (int, int, int, int)
        Lines beyond the first column, the last column, the first row and the last row: the board
        seems to have ``cols + first + second`` x ``rows + third + fourth`` inner corners. A line
        that would leave the image is not counted (the board may go on there, unseen).
    """
    g = np.asarray(corners, float).reshape(rows, cols, 2)
    u = np.gradient(g, axis=1).reshape(-1, 2)
    v = np.gradient(g, axis=0).reshape(-1, 2)
    contrast, _ = corner_likeness(gray, g.reshape(-1, 2), u, v)
    ref = float(np.median(contrast))
    # each side turned to be "after the last column" of a grid whose lines run along axis 1
    sides = (g[:, ::-1], g, g.transpose(1, 0, 2)[:, ::-1], g.transpose(1, 0, 2))
    first_col, last_col, first_row, last_row = (_count_beyond(gray, s, ref, most) for s in sides)
    return first_col, last_col, first_row, last_row


def skipped_lines(gray: np.ndarray, corners: np.ndarray, cols: int, rows: int) -> tuple[int, int]:
    """Lines of inner corners the grid found steps over: a detector asked for fewer corners
    than the board has may return a grid that spans the board by skipping a line.

    Parameters
    ----------
    gray : ndarray, shape (h, w)
        The image the grid was found in.
    corners : ndarray, shape (rows * cols, 2)
        The grid found, row-major (``cols`` per row), px.
    cols, rows : int
        The grid's size, inner corners (each at least 2).

    Returns
    -------
    (int, int)
        The gaps between neighbouring columns, and between neighbouring rows, halfway across
        which every point is a corner (a line of the board the grid stepped over).
    """
    g = np.asarray(corners, float).reshape(rows, cols, 2)
    u, v = np.gradient(g, axis=1), np.gradient(g, axis=0)
    contrast, _ = corner_likeness(gray, g.reshape(-1, 2), u.reshape(-1, 2), v.reshape(-1, 2))
    ref = float(np.median(contrast))
    out = []
    # between columns k and k + 1 (steps along u), then between rows (the grid turned)
    for grid, across in ((g, v), (g.transpose(1, 0, 2), u.transpose(1, 0, 2))):
        gaps = 0
        for k in range(grid.shape[1] - 1):
            a, b = grid[:, k], grid[:, k + 1]
            # a line skipped: the real step is half the gap
            c, alike = corner_likeness(gray, (a + b) / 2, (b - a) / 2, across[:, k])
            gaps += bool(ref > 0 and np.all((c > _CONTRAST * ref) & (alike < _ALIKE * c)))
        out.append(gaps)
    return out[0], out[1]


def seeming_size(gray: np.ndarray, corners: np.ndarray, cols: int, rows: int) -> tuple[int, int]:
    """The inner corners (cols, rows) the board seems to have, from the grid found: its own,
    the lines it stepped over (:func:`skipped_lines`) and those beyond it (:func:`extra_lines`);
    ``(cols, rows)`` where the grid is the whole board.

    Parameters
    ----------
    gray : ndarray, shape (h, w)
        The image the grid was found in.
    corners : ndarray, shape (rows * cols, 2)
        The grid found, row-major, px.
    cols, rows : int
        The grid's size, inner corners.

    Returns
    -------
    (int, int)
        The board's columns and rows of inner corners, as far as the image shows them.
    """
    first_col, last_col, first_row, last_row = extra_lines(gray, corners, cols, rows)
    col_gaps, row_gaps = skipped_lines(gray, corners, cols, rows)
    return cols + first_col + last_col + col_gaps, rows + first_row + last_row + row_gaps


def _count_beyond(gray: np.ndarray, grid: np.ndarray, ref: float, most: int) -> int:
    """Lines of corners after ``grid``'s last column (grid: (lines, k, 2) px), each predicted
    from the last ones, refined, and kept while every point of it is a corner."""
    h, w = gray.shape[:2]
    n = 0
    while n < most and ref > 0:
        last = grid[:, -1]
        if grid.shape[1] >= 3:
            nxt = 3 * last - 3 * grid[:, -2] + grid[:, -3]
        else:
            nxt = 2 * last - grid[:, -2]
        u = nxt - last
        step = float(np.linalg.norm(u, axis=1).max())
        # the next line and its squares must lie inside the image
        if step < 2 or nxt.min() < step or nxt[:, 0].max() > w - 1 - step:
            break
        if nxt[:, 1].max() > h - 1 - step:
            break
        half = int(np.clip(round(0.3 * float(np.median(np.linalg.norm(u, axis=1)))), 2, 10))
        nxt = refine_saddle(gray, nxt, half)
        contrast, alike = corner_likeness(gray, nxt, nxt - last, np.gradient(nxt, axis=0))
        if not np.all((contrast > _CONTRAST * ref) & (alike < _ALIKE * contrast)):
            break
        grid = np.concatenate([grid, nxt[:, None]], axis=1)
        n += 1
    return n
