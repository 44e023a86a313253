"""The arm's task-specific uncertainty: the compensated point error over its workspace.

The task: the calibrated arm's point at each of a grid of postures against where its tool truly
is, in the tracker's frame, x, y and z (um). One trial draws a machine from the as-built error
distribution (:func:`~calibench.scenarios.arm_cmm.scenario.prior`), records it with the tracker
at :data:`CALIBRATION_POSTURES` random postures, calibrates it as ``fit`` does and evaluates
the error at the grid's postures; the Monte Carlo of those trials is the task's distribution.

The GUM framework's answer beside it: the calibration's covariance (a reference machine's, the
study's seed) propagated to each grid point by the task's Jacobian, the model's point with
respect to the kept parameters, about a mean error of zero::

    u(y_g)^2 = J_g C J_g^T,    interval y_g +- 1.96 u(y_g)
"""

from __future__ import annotations

import numpy as np

from calibench.estimators.arm.calibration import ArmCalibration, calibrate
from calibench.estimators.arm.point import PointProblem
from calibench.scenarios.arm_cmm.acceptance import CALIBRATION_POSTURES, tracker_xyz
from calibench.scenarios.arm_cmm.arms import chain_of
from calibench.scenarios.arm_cmm.scenario import ArmCmmConfig, prior
from calibench.scenes.arm_cmm import load_arm
from calibench.sim.arm_cmm import ArmSim

GRID_POSTURES = 12  # the task's places over the workspace
GRID_SEED = 20_241  # the grid's own draw: the same grid for every trial and machine
TASK = "compensated point error of the calibrated arm, tracker frame"
UNIT = "um"


def grid(config: ArmCmmConfig) -> tuple[np.ndarray, np.ndarray]:
    """The task's grid: postures (G, N) drawn over the arm's ranges with the tool above the
    floor, and their tool points (G, 3) mm on the drawing (where the map puts them)."""
    arm = load_arm(config.arm) if isinstance(config.arm, str) else config.arm
    sim = ArmSim(arm)
    q = sim.random_postures(GRID_POSTURES, np.random.default_rng(GRID_SEED))
    return q, sim.probe_mm(q)


def labels(points_mm: np.ndarray) -> list[dict]:
    """Each quantity's place and name, (3 G) in the order of :func:`trial`'s values."""
    return [
        {"at": {f"{a}_mm": round(float(v), 1) for a, v in zip("xyz", p)}, "quantity": axis}
        for p in points_mm
        for axis in "xyz"
    ]


def calibrated(config: ArmCmmConfig, seed: int) -> tuple[ArmSim, ArmCalibration]:
    """A machine drawn by ``seed`` and its calibration on a simulated tracker recording."""
    rng = np.random.default_rng(seed)
    drawn = prior(config, rng)
    sim = ArmSim(drawn.arm, drawn.truth)
    chain = chain_of(sim.arm)
    q = sim.random_postures(CALIBRATION_POSTURES, rng)
    xyz = tracker_xyz(sim, q, rng)
    model = "physics" if chain.has_masses else "geometry"
    return sim, calibrate(chain, sim.encoders(q, rng), xyz, np.zeros(len(q), int), None, model)


def trial(config: ArmCmmConfig, grid_q: np.ndarray, seed: int) -> np.ndarray:
    """One trial's compensated errors (3 G,) um: the calibrated model's point at each grid
    posture minus the true one, both in the tracker's frame."""
    sim, cal = calibrated(config, seed)
    R, t = sim.base2tracker()
    truth = sim.probe_mm(grid_q) @ R.T + t
    return 1000 * (cal.problem.model(cal.state, grid_q, frame=0) - truth).ravel()


def gum(config: ArmCmmConfig, grid_q: np.ndarray, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """The GUM framework's inputs for each grid point's error: the task's Jacobian (3 G, P) um
    per parameter unit (the model's point with respect to the kept parameters, at the reference
    machine's calibration) and that calibration's covariance (P, P)."""
    _, cal = calibrated(config, seed)
    if cal.ident.cov is None:
        raise RuntimeError("the calibration returned no covariance")
    return 1000 * task_jacobian(cal, grid_q), cal.ident.cov


def task_jacobian(cal: ArmCalibration, grid_q: np.ndarray) -> np.ndarray:
    """d(the calibrated model's points at ``grid_q`` (G, N), tracker frame) / d(its kept
    parameters), (3 G, P) mm per parameter unit: the point problem's own Jacobian at those
    postures, unweighted (the residual's sign undone)."""
    p = cal.problem
    at = PointProblem(
        p.chain,
        grid_q,
        np.zeros((len(grid_q), 3)),
        compliance_joints=p.cj,
        tilt_joints=p.tj,
        angle_terms=p.terms,
        cable_motors=p.cm,
    )
    at.R_ref = p.R_ref
    return -at.jacobian(cal.state)[:, cal.ident.basis.kept]
