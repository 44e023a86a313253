"""The belt stage's task-specific uncertainty: the compensated position error over its travel.

The task: at each target of a grid over the travel, the stage commanded through its fitted error
maps (:func:`~calibench.estimators.stage.error_map.compensated_command`) and where it truly goes,
x and y (um). One trial draws a machine from the scenario's prior (its maps' coefficients and
the board's yaw), renders nothing (the analytic camera: exact projection plus the detector's
noise), calibrates the camera, measures the stations, fits both maps and commands the grid.

The GUM framework's answer: the two maps' coefficients' whole covariance C (each map's own
scatter with its least-squares design's correlation, and the intrinsics' and the plane of
motion's errors carried through every station at once, which move both maps together), as the
scenario's reported std is its diagonal, propagated to each target by the map's monomials there
(a compensated error moves by minus what the map's value does)::

    u(e_g)^2 = a_g^T C a_g,    a_g = the monomials at target g
"""

from __future__ import annotations

import numpy as np

from calibench.estimators.stage.belt_maps import (
    MAP_INTRINSICS,
    intrinsics_cov,
    measure_maps,
    propagated_cov,
)
from calibench.estimators.stage.compensation import MONOMIAL_SCALE_MM, design, monomial_powers
from calibench.estimators.stage.error_map import compensated_command
from calibench.scenarios.belt_stage.procedure import (
    calibrate,
    calibration_points,
    intrinsic_views,
    measure,
    station_views,
)
from calibench.scenarios.belt_stage.scenario import BeltStageConfig, prior
from calibench.scenarios.uncertainty import plane_labels
from calibench.sim.belt_stage import PULSES_PER_MM, BeltStageSim

GRID = (4, 3)  # targets along x and y, inside the travel's outer tenth
TASK = "compensated position error of the stage, x and y"
UNIT = "um"


def grid(config: BeltStageConfig) -> tuple[np.ndarray, np.ndarray]:
    """The task's targets (G, 2) mm over the travel, and their points (G, 3) mm (z = 0)."""
    tx, ty = config.geometry.travel_mm
    xs = np.linspace(0.1 * tx, 0.9 * tx, GRID[0])
    ys = np.linspace(0.1 * ty, 0.9 * ty, GRID[1])
    targets = np.array([(x, y) for y in ys for x in xs])
    return targets, np.c_[targets, np.zeros(len(targets))]


def labels(points_mm: np.ndarray) -> list[dict]:
    """Each quantity's place and name, (2 G) in the order of :func:`trial`'s values."""
    return plane_labels(points_mm)


def measured_maps(config: BeltStageConfig, seed: int):
    """A machine drawn by ``seed``, its maps measured with their standard deviations; returns
    (sim, maps)."""
    sim, drawn, board, stations, calib, points = _calibrated(config, seed)
    return sim, measure(board, stations, calib, points)


def _calibrated(config: BeltStageConfig, seed: int):
    """A machine drawn by ``seed``, its camera calibrated on its views: (sim, the drawn config,
    the board's corners, the stations' views, the calibration, the views it took)."""
    rng = np.random.default_rng(seed)
    drawn = prior(config, rng)
    sim = BeltStageSim(drawn.geometry, drawn.truth, render=False)
    board = drawn.geometry.board.corners_mm()
    intrinsic = intrinsic_views(sim, drawn, "analytic", rng, True, 0)
    stations = station_views(sim, drawn, "analytic", rng, True, 0)
    points = calibration_points(intrinsic, stations)
    return sim, drawn, board, stations, calibrate(drawn, board, points), points


def trial(config: BeltStageConfig, targets: np.ndarray, seed: int) -> np.ndarray:
    """One trial's compensated errors (2 G,) um: where the stage goes for each target's
    compensated command, less the target. The maps as :func:`measured_maps` measures them,
    without their standard deviations (the GUM's alone: a fifth of a trial's time)."""
    sim, _, board, stations, calib, _ = _calibrated(config, seed)
    m = measure_maps(board, stations.corners_px, calib.K, calib.dist, stations.cmd_mm, stations.ref)
    try:
        cmd = np.stack(compensated_command(targets[:, 0], targets[:, 1], m.fit_x, m.fit_y), 1)
        went = np.array([sim.move(*np.rint(c * PULSES_PER_MM)) for c in cmd])
    finally:
        sim.close()
    return 1000 * (went - targets).ravel()


def gum(config: BeltStageConfig, targets: np.ndarray, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """The task's Jacobian (2 G, 12) um per coefficient unit (minus each map's monomials at the
    targets) and the two maps' coefficient covariance (12, 12) of the reference machine, whole:
    each map's own with its design's correlation, and the intrinsics' and the plane's common
    modes across both (:func:`~calibench.estimators.stage.belt_maps.propagated_cov`)."""
    sim, _, board, stations, calib, points = _calibrated(config, seed)
    sim.close()
    cmd, ref = stations.cmd_mm, stations.ref
    m = measure_maps(board, stations.corners_px, calib.K, calib.dist, cmd, ref)
    cov_intr = intrinsics_cov(calib, board, points)
    cov = propagated_cov(m, board, calib.K, calib.dist, cmd, ref, MAP_INTRINSICS, cov_intr)
    return 1000 * task_jacobian(targets), cov[:12, :12]


def task_jacobian(targets: np.ndarray) -> np.ndarray:
    """d(compensated error at each target, x and y) / d(the maps' coefficients, x's then y's),
    (2 G, 12) mm per coefficient unit: minus each map's monomials at the targets (the command
    moves against what the map's value does, to first order)."""
    scale = MONOMIAL_SCALE_MM ** np.array([i + j for i, j in monomial_powers(2)])
    a = design(targets[:, 0], targets[:, 1], 2) * scale  # (G, 6)
    J = np.zeros((2 * len(targets), 12))
    J[0::2, :6], J[1::2, 6:] = -a, -a
    return J
