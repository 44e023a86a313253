"""How the ``vision-stage`` run drives the machine: the microscope that finds a circle, the servo
that centres it, the plate's rotate-and-check alignment, the line rulers read by eye, and the
laser interferometer's bidirectional runs (ISO 230-2).

Each step moves the simulation and returns what its instrument records; the truth it keeps (the
true image of a circle's centre, the plate's true angle) stays beside it for the report.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from calibench.estimators.camera.circles import find_dark_circle
from calibench.estimators.stage import iso230_2
from calibench.estimators.stage.circle_plate import plate_angle_rad
from calibench.estimators.stage.compensation import LineRuler, compensated_command
from calibench.sim.vision_stage import LineRuler as RulerArtefact
from calibench.sim.vision_stage import VisionStageSim

if TYPE_CHECKING:
    from calibench.scenarios.vision_stage.scenario import VisionStageConfig

# beyond the circle's rim in an area-of-interest read-out: the detector searches the rim's
# contour +-5 px (the contour within a pixel of the rim), reads its smoothed image there (a
# 4 px kernel, a bilinear pixel), and the optics' blur reflected at the read-out's edge reaches
# 4 px in: 1 + 5 + 4 + 1 + 4 < 16
WINDOW_MARGIN_PX = 16
# measure_rulers lays each ruler over the travel less this (its ends clear)
RULER_SHORTER_BY_MM = 10.0


class Microscope:
    """Finds the circle nearest the image centre; keeps the true centres for the report."""

    def __init__(
        self, sim: VisionStageSim, config: VisionStageConfig, fidelity: str, windowed: bool = False
    ):
        self.sim, self.config, self.fidelity = sim, config, fidelity
        cam = config.geometry.camera
        self.centre = np.array([cam.cx, cam.cy])
        self.mm_per_px = config.geometry.working_distance_mm / cam.fx
        # a study's trial keeps no image: the circle's area of interest is read out alone
        self.windowed = windowed
        self.errors_px: list[np.ndarray] = []  # detected - true, every measurement
        self.last_image: np.ndarray | None = None
        self.last_found: np.ndarray | None = None
        self.last_true: np.ndarray | None = None

    def offset_mm(self) -> np.ndarray:
        """Where the nearest circle's centre is from the image centre, in machine X, Y (mm)."""
        true = self._nearest_true()
        if self.fidelity == "render":
            window = self._window(true) if self.windowed else None
            img = self.sim.render(self.config.pixel_noise_dn, self.config.psf_px, window)
            offset = np.zeros(2) if window is None else np.array(window[:2], float)
            fit = find_dark_circle(img, near=self.centre - offset)
            if fit is None:
                raise ValueError(
                    f"no whole circle in the microscope's view at reading {self.sim.reading_mm}"
                )
            found = fit.centre + offset
            self.last_image = img
        else:
            found = true + self.sim.rng.normal(0, self.config.centre_noise_px, 2)
        self.errors_px.append(found - true)
        self.last_found, self.last_true = found, true
        d = found - self.centre
        # image x runs along machine X; image v runs against machine Y
        return np.array([d[0], -d[1]]) * self.mm_per_px

    def _window(self, centre_px: np.ndarray) -> tuple[int, int, int, int]:
        """The area of interest around the circle at ``centre_px``: its radius and
        :data:`WINDOW_MARGIN_PX` each way, inside the image."""
        cam, plate = self.config.geometry.camera, self.config.geometry.plate
        reach = plate.diameter_mm / 2 / self.mm_per_px + WINDOW_MARGIN_PX
        lo = np.maximum(np.floor(centre_px - reach).astype(int), 0)
        hi = np.minimum(np.ceil(centre_px + reach).astype(int) + 1, [cam.width, cam.height])
        return int(lo[0]), int(lo[1]), int(hi[0]), int(hi[1])

    def _nearest_true(self) -> np.ndarray:
        p = self.sim.point_in_body_mm("plate")
        plate = self.config.geometry.plate
        i, j = np.clip(np.rint(p / plate.pitch_mm), 0, plate.n - 1).astype(int)
        return self.sim.true_circle_px(j * plate.n + i)


def approach(sim: VisionStageSim, reading: np.ndarray) -> None:
    """Move to a reading from below on both axes (unidirectional approach)."""
    sim.move_path(np.array([reading - 0.02, reading], float))


def servo(
    sim: VisionStageSim, scope: Microscope, reading: np.ndarray, tol_px: float
) -> tuple[np.ndarray, int]:
    """Move until the nearest circle is within ``tol_px`` of the image centre.

    Returns the reading at which the circle's centre is on the optical axis (the final reading
    plus the residual offset measured in the last image) and the number of moves.
    """
    s = np.array(reading, float)
    for n in range(1, 8):
        approach(sim, s)
        off = scope.offset_mm()
        if np.all(np.abs(off) < tol_px * scope.mm_per_px):
            return s + off, n
        s = s + off
    raise ValueError(f"servo did not settle near reading {reading}")


def predicted_correction(corrections: np.ndarray, k: int, nx: int) -> np.ndarray:
    """Where circle ``k`` of the grid will be found, as the correction its nominal reading will
    need, from the circles already servoed (row by row, ``nx`` a row): the error field is smooth,
    so the last two of the row extrapolated, or the circle below at a row's start.

    Args:
        corrections: (k, 2) reading less nominal reading (mm) of each circle servoed so far.
        k: the circle about to be servoed.
        nx: circles in a row.

    Returns:
        (2,) the predicted correction (mm): zero for the first circle.
    """
    col = k % nx
    if col >= 2:
        return 2 * corrections[k - 1] - corrections[k - 2]
    if col == 1:
        return corrections[k - 1]
    return corrections[k - nx] if k >= nx else np.zeros(2)


def align_plate(sim, scope, config, rng):
    """The rotate-and-check loop. Returns (phi estimates in order, truths in order, s00)."""
    g = config.geometry
    pitch = g.plate.pitch_mm
    far = (config.grid[0] - 1) * pitch
    estimates, truths, turns = [], [], 0
    while True:
        s00, _ = servo(sim, scope, np.array(g.plate_origin_reading_mm), config.servo_tolerance_px)
        # a near circle first, so the far one can be found even when phi is large
        s_near, _ = servo(sim, scope, s00 + [4 * pitch, 0], config.servo_tolerance_px)
        coarse = plate_angle_rad(s00, s_near)
        s_far, _ = servo(
            sim,
            scope,
            s00 + far * np.array([np.cos(coarse), np.sin(coarse)]),
            config.servo_tolerance_px,
        )
        estimates.append(plate_angle_rad(s00, s_far))
        truths.append(true_phi(sim, s00, s00 + [far, 0.0]))
        if (
            abs(estimates[-1]) * 1e6 <= config.align_tolerance_urad
            or turns >= config.align_max_turns
        ):
            return estimates, truths, s00
        # the operator turns the plate about circle (0, 0), imperfectly
        turn = -estimates[-1] * (1 + config.turn_error * rng.standard_normal())
        turn += config.turn_noise_urad * 1e-6 * rng.standard_normal()
        sim.set_plate_yaw(sim.plate_phi_rad + turn)
        turns += 1


def true_phi(sim: VisionStageSim, s_a: np.ndarray, s_b: np.ndarray) -> float:
    """The plate's angle to the X motion from reading s_a to s_b (a pure X move), from the
    geometric truth: that motion, seen in plate coordinates, turns by -phi."""
    d = sim.true_point_mm(s_b[0], s_b[1], body="plate") - sim.true_point_mm(
        s_a[0], s_a[1], body="plate"
    )
    return float(-np.arctan2(d[1], d[0]))


def measure_rulers(sim: VisionStageSim, config: VisionStageConfig, rng, s00) -> list[LineRuler]:
    """Lay a ruler along X through the middle of the grid and one along Y, read them (Eq. 3)."""
    g = config.geometry
    out = []
    for axis in (0, 1):
        length = g.travel_mm[axis] - RULER_SHORTER_BY_MM
        n = int(length // config.ruler_pitch_mm) + 1
        other = 1 - axis
        mid = s00[other] + (config.grid[other] - 1) * g.plate.pitch_mm / 2
        origin = np.zeros(2)
        origin[axis], origin[other] = 4.0, mid
        angle = (0.0 if axis == 0 else np.pi / 2) + config.ruler_parallelism_urad * 1e-6
        ruler = RulerArtefact(
            origin_mm=origin,
            angle_rad=angle,
            pitch_mm=config.ruler_pitch_mm,
            graduation_errors_mm=rng.normal(0, config.ruler_error_um / 1000, n),
        )
        readings = [sim.ruler_reading(ruler, k, axis, mid, config.ruler_aim_um) for k in range(n)]
        out.append(LineRuler.from_graduations(np.array(readings), config.ruler_pitch_mm))
    return out


def interferometer_lines(config: VisionStageConfig, rng) -> list[tuple[int, float, np.ndarray]]:
    """(axis, other axis's coordinate, targets) of every line; targets irregularly spaced, as
    ISO 230-2 asks, so that periodic errors are not sampled in step, and inside the range the
    plate calibrated (a model is not tested where it extrapolates)."""
    g = config.geometry
    lines = []
    for axis, others in ((0, config.x_lines_at_y_mm), (1, config.y_lines_at_x_mm)):
        m = config.targets_per_line
        lo = g.plate_origin_reading_mm[axis] + 3.0
        hi = g.plate_origin_reading_mm[axis] + (config.grid[axis] - 1) * g.plate.pitch_mm - 3.0
        base = np.linspace(lo, hi, m)
        jitter = rng.uniform(-0.3, 0.3, m) * (base[1] - base[0])
        jitter[[0, -1]] = 0.0
        for o in others:
            lines.append((axis, o, base + jitter))
    return lines


def interferometer_test(sim, config, lines, model) -> list[dict]:
    """Bidirectional runs along each line: deviations (actual - target, um) and ISO 230-2."""
    out = []
    for axis, other, targets in lines:
        m, n = len(targets), config.runs
        # every position's compensated command, the same in every run: solved once, all at once
        along = np.r_[
            targets, targets[0] - 2.0, targets[-1] + 2.0
        ]  # the targets, then both overruns
        points = np.empty((m + 2, 2))
        points[:, axis], points[:, 1 - axis] = along, other
        commands = compensated_command(points, model)
        # each run: the overrun below, the targets up, the overrun above, the targets down
        up, down = np.r_[m, 0:m], np.r_[m + 1, m - 1 : -1 : -1]
        path = np.tile(np.r_[up, down], n)
        readings = sim.move_path(commands[path], path < m, axis, config.interferometer_noise_um)
        readings = readings.reshape(n, 2, m)  # run, direction (up, down), in the order of travel
        zero = readings[0, 0, 0] - targets[0]  # zeroed at the first target of the first run
        dev = {
            +1: ((readings[:, 0] - zero - targets) * 1000).T,
            -1: ((readings[:, 1, ::-1] - zero - targets) * 1000).T,
        }
        res = iso230_2.evaluate(targets, dev[+1], dev[-1])
        out.append(
            {
                "axis": "xy"[axis],
                "at_mm": other,
                "targets_mm": targets,
                "dev_up_um": dev[+1],
                "dev_down_um": dev[-1],
                "iso": res,
            }
        )
    return out
