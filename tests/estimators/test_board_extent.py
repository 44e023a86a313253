"""A chessboard's extent beyond the grid a detector found: a part of a board is told from the
whole (issue 59: `camera --cols 7` on a 9-column board calibrated on a 7 x 6 part of it)."""

import numpy as np
import pytest

from calibench.estimators.camera.board_extent import extra_lines, seeming_size, skipped_lines

SQUARE, MARGIN = 30, 45  # px


def _board(cols: int, rows: int) -> tuple[np.ndarray, np.ndarray]:
    """A (cols + 1) x (rows + 1)-square board on a white margin, slightly blurred, and its inner
    corners (rows * cols, 2) row-major, px."""
    import cv2

    w, h = (cols + 1) * SQUARE + 2 * MARGIN, (rows + 1) * SQUARE + 2 * MARGIN
    img = np.full((h, w), 230, np.uint8)
    for i in range(rows + 1):
        for j in range(cols + 1):
            if (i + j) % 2 == 0:
                y, x = MARGIN + i * SQUARE, MARGIN + j * SQUARE
                img[y : y + SQUARE, x : x + SQUARE] = 25
    img = cv2.GaussianBlur(img, (0, 0), 1.0)
    jj, ii = np.meshgrid(np.arange(1, cols + 1), np.arange(1, rows + 1))
    corners = np.stack([MARGIN + jj * SQUARE - 0.5, MARGIN + ii * SQUARE - 0.5], axis=2)
    return img, corners.reshape(-1, 2).astype(float)


def test_the_whole_board_shows_no_corner_beyond_its_grid():
    img, corners = _board(9, 6)
    assert extra_lines(img, corners, 9, 6) == (0, 0, 0, 0)
    assert skipped_lines(img, corners, 9, 6) == (0, 0)
    assert seeming_size(img, corners, 9, 6) == (9, 6)


def test_a_grid_that_steps_over_lines_of_the_board_is_told():
    """Columns 0, 1, 3, 5, 6, 7, 8 and rows 0, 2, 3, 4, 5 of a 9 x 6 board (a detector asked for
    7 x 5 may return such a grid): two columns and one row stepped over, the board 9 x 6."""
    img, corners = _board(9, 6)
    grid = corners.reshape(6, 9, 2)[[0, 2, 3, 4, 5]][:, [0, 1, 3, 5, 6, 7, 8]]
    assert skipped_lines(img, grid.reshape(-1, 2), 7, 5) == (2, 1)
    assert seeming_size(img, grid.reshape(-1, 2), 7, 5) == (9, 6)


@pytest.mark.parametrize(("first_col", "cols", "first_row", "rows"), [(1, 7, 0, 6), (0, 9, 2, 3)])
def test_a_part_of_the_board_shows_the_lines_beyond_it(first_col, cols, first_row, rows):
    """A 7 x 6 part (one column left out each side) and a 9 x 3 part (two rows above, one
    below): the lines counted on each side add up to the board's 9 x 6."""
    img, corners = _board(9, 6)
    grid = corners.reshape(6, 9, 2)[first_row : first_row + rows, first_col : first_col + cols]
    extra = extra_lines(img, grid.reshape(-1, 2), cols, rows)
    assert extra == (first_col, 9 - cols - first_col, first_row, 6 - rows - first_row)


def test_a_board_going_out_of_the_image_is_not_counted_beyond_it():
    """A line whose squares would leave the image is unseen, so not counted (the board may end
    there): the image cut a sixth of a square beyond the last column, the 7 x 6 part at its left
    shows one column more, not two."""
    img, corners = _board(9, 6)
    crop = img[:, : MARGIN + 9 * SQUARE + 5]
    grid = corners.reshape(6, 9, 2)[:, :7]
    assert extra_lines(crop, grid.reshape(-1, 2), 7, 6) == (0, 1, 0, 0)
