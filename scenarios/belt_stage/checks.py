"""What makes a belt-stage set-up workable: the config's checks, made before any simulation."""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

import numpy as np

from calibench.errors import BadInput
from calibench.scenarios.belt_stage import NAME
from calibench.scenes.belt_stage import BeltStageGeometry
from calibench.scenes.checkerboard import TEXTURE_PX_PER_SQUARE
from calibench.sim.belt_stage import INTRINSIC_VIEW_DEPTH_MM, PULSES_PER_MM

if TYPE_CHECKING:  # the config's module imports this one
    from calibench.scenarios.belt_stage.scenario import BeltStageConfig


# What the config's checks hold the set-up to (see check_config).
MAX_ERROR_FRACTION = 0.1  # a positioning error over 10 % of the travel is not a calibration error
MAX_BOARD_FRACTION = 0.8  # the board's share of the image at the calibration views' far depth
MIN_SQUARE_PX = 5.0  # a square's side in the station views: the detector needs a few pixels


def check_config(c: BeltStageConfig) -> None:
    """What makes a belt-stage set-up workable, checked before any simulation (BadInput, one line
    naming the key): a calibratable lens, a board the camera sees over the whole travel and in its
    tilted calibration views, stations inside the travel that span the quadratic maps, and error
    maps that are errors."""
    from calibench.scenarios.config import check_camera

    check_camera(c.geometry.camera, f"{NAME}.geometry.camera")
    check_board(c.geometry)
    in_view = check_camera_height(c.geometry)
    check_error_maps(c, in_view)
    check_stations(c)


def check_board(g: BeltStageGeometry) -> None:
    """The board fits the image in the tilted calibration views, and its texture has whole
    pixels in its margin (BadInput naming ``square_mm``)."""
    from calibench.scenarios.config import bad

    where = f"{NAME}.geometry"
    cam, board = g.camera, g.board
    # the calibration views hold the tilted board in front of the camera, as far as this
    far = INTRINSIC_VIEW_DEPTH_MM[1]
    w_mm, h_mm = board.size_mm
    share = max(w_mm * cam.fx / far / cam.width, h_mm * cam.fy / far / cam.height)
    if share > MAX_BOARD_FRACTION:
        # the board is (cols + 1, rows + 1) squares and two margins: the largest square that fits
        most = min(
            (MAX_BOARD_FRACTION * far * size / f - 2 * board.margin_mm) / (n + 1)
            for size, f, n in ((cam.width, cam.fx, board.cols), (cam.height, cam.fy, board.rows))
        )
        raise bad(
            f"{where}.board.square_mm",
            board.square_mm,
            f"the {w_mm:g} x {h_mm:g} mm board spans {share:.3g} times the image at {far:g} mm, "
            "the far end of "
            f"the tilted calibration views: at most {MAX_BOARD_FRACTION:g}, square_mm up to "
            f"{max(most, 0.0):.3g} with this board and camera",
        )
    # the board's texture: whole texture pixels in the margin, as Chessboard.texture needs
    m = board.margin_mm / board.square_mm * TEXTURE_PX_PER_SQUARE
    if abs(m - round(m)) > 1e-9:
        near = sorted(
            {board.margin_mm * TEXTURE_PX_PER_SQUARE / k for k in (max(1, int(m)), int(m) + 1)}
        )
        raise bad(
            f"{where}.board.square_mm",
            board.square_mm,
            f"the margin ({board.margin_mm:g} mm) must be a whole number of "
            f"1/{TEXTURE_PX_PER_SQUARE} squares (the board's texture pixels): e.g. square_mm = "
            f"{' or '.join(f'{q:.6g}' for q in near)}",
        )


def check_camera_height(g: BeltStageGeometry) -> Callable[[float, float], bool]:
    """The camera above the middle of the travel sees the board anywhere in it (BadInput naming
    ``camera_height_mm``). Returns whether the board's corners stay in the image over the travel
    widened by ex, ey mm: ``in_view(ex, ey)``."""
    from calibench.scenarios.config import show

    where = f"{NAME}.geometry"
    cam, board = g.camera, g.board
    w_mm, h_mm = board.size_mm
    # the board in view over the whole travel (the camera hangs above its middle)
    tx, ty = g.travel_mm
    depth = g.camera_height_mm - g.board_top_mm

    def in_view(ex: float, ey: float) -> bool:
        """Whether the board's corners stay in the image over the travel widened by ex, ey mm."""
        xs, ys = np.array([-ex, tx + ex]), np.array([-ey, ty + ey])
        px, py = np.meshgrid(
            np.r_[xs - w_mm / 2, xs + w_mm / 2], np.r_[ys - h_mm / 2, ys + h_mm / 2]
        )
        pts = np.stack(
            [px.ravel() - tx / 2, -(py.ravel() - ty / 2), np.full(px.size, depth)], axis=1
        )
        with np.errstate(all="ignore"):
            uv = cam.project(pts)
        return bool(np.all(np.isfinite(uv) & (uv >= 0) & (uv <= [cam.width - 1, cam.height - 1])))

    need = g.board_top_mm + max(
        (span / 2 + side / 2) * f / min(cc, size - 1 - cc)
        for span, side, f, cc, size in (
            (tx, w_mm, cam.fx, cam.cx, cam.width),
            (ty, h_mm, cam.fy, cam.cy, cam.height),
        )
    )
    what = (
        f"camera_height_mm = {show(g.camera_height_mm)} with travel_mm = {show(g.travel_mm)}: the "
        "camera above "
        f"the middle of the travel must see the {w_mm:g} x {h_mm:g} mm board anywhere in the travel"
    )
    if depth <= 0:
        raise BadInput(
            f"config: {where}: {what}; it hangs below the board's face (board_top_mm = "
            f"{g.board_top_mm:g}): camera_height_mm at least about {need:.4g}"
        )
    if not in_view(0.0, 0.0):
        raise BadInput(
            f"config: {where}: {what}; the board leaves the {cam.width} x {cam.height} image: "
            f"camera_height_mm at least about {need:.4g} for this travel, or a shorter travel"
        )
    return in_view


def check_error_maps(c: BeltStageConfig, in_view: Callable[[float, float], bool]) -> None:
    """The injected error maps are errors, not a different machine (within a tenth of the
    travel), that keep the board ``in_view``; and a square spans enough pixels for the
    detector (BadInput naming the key)."""
    from calibench.scenarios.config import bad

    g, where = c.geometry, f"{NAME}.geometry"
    cam, board = g.camera, g.board
    tx, ty = g.travel_mm
    depth = g.camera_height_mm - g.board_top_mm
    # the injected error maps: errors, not a different machine, that keep the board in view
    t = c.truth
    gx, gy = np.meshgrid(np.linspace(0, tx, 5), np.linspace(0, ty, 5))
    err = np.abs(t.error_mm(gx.ravel(), gy.ravel())).max(axis=0)
    for k, key in enumerate(("error_x", "error_y")):
        limit = MAX_ERROR_FRACTION * (tx, ty)[k]
        if not err[k] <= limit:
            raise bad(
                f"{NAME}.truth.{key}",
                getattr(t, key),
                f"the map reaches {err[k]:.4g} mm in the travel: a positioning error is at most "
                f"{MAX_ERROR_FRACTION:.0%} of the travel ({limit:g} mm)",
            )
    if not in_view(*err):
        key = "error_x" if not in_view(err[0], 0.0) else "error_y"
        raise bad(
            f"{NAME}.truth.{key}",
            getattr(t, key),
            f"the map moves the board up to {err[int(key == 'error_y')]:.4g} mm, out of the "
            f"camera's view at the edge of the travel (camera_height_mm = {g.camera_height_mm:g})",
        )
    if board.square_mm * min(cam.fx, cam.fy) / depth < MIN_SQUARE_PX:
        raise bad(
            f"{where}.board.square_mm",
            board.square_mm,
            f"a square spans {board.square_mm * min(cam.fx, cam.fy) / depth:.3g} px in the "
            "station views "
            f"({depth:g} mm from the camera): the corner detector needs {MIN_SQUARE_PX:g} px or "
            "more",
        )


def check_stations(c: BeltStageConfig) -> None:
    """The stations lie inside the travel, hold home once, each once, and are enough distinct
    ones for the quadratic maps (BadInput naming the key)."""
    from calibench.scenarios.config import bad

    tx, ty = c.geometry.travel_mm
    # stations: inside the travel, home once, enough distinct ones for the quadratic maps
    # a quadratic in x (1, x, x^2) needs three distinct x, and so in y; 3 x 3 > 6 coefficients
    n_min = 3
    for axis, (key, stations, travel) in enumerate(
        (("stations_x_mm", c.stations_x_mm, tx), ("stations_y_mm", c.stations_y_mm, ty))
    ):
        s = np.asarray(stations, float)
        pulses = np.rint(s * PULSES_PER_MM)
        if len(s) and not np.all((s >= 0) & (s <= travel)):
            raise bad(
                f"{NAME}.{key}",
                stations,
                f"stations lie within the {'XY'[axis]} travel: from 0 to {travel:g} mm (travel_mm)",
            )
        if np.count_nonzero(pulses == 0) != 1:
            raise bad(
                f"{NAME}.{key}",
                stations,
                "the stations hold the home station 0 once (the stage is homed "
                "there, the errors are measured from it)",
            )
        if len(np.unique(pulses)) != len(pulses):
            raise bad(
                f"{NAME}.{key}",
                stations,
                f"each station once (to the {1 / PULSES_PER_MM:g} mm of a pulse)",
            )
        if len(s) < n_min:
            raise bad(
                f"{NAME}.{key}",
                stations,
                f"at least {n_min} distinct stations: the quadratic error map "
                f"(c0 + c1 x + c2 y + c3 x^2 + c4 x y + c5 y^2) needs {n_min} along each axis",
            )
