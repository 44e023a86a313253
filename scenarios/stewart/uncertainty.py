"""The Stewart platform's task-specific uncertainty: the compensated pose error over its
workspace.

The task: the platform commanded to each of a grid of poses through its calibrated model (the
legs' readings from inverse kinematics with the calibrated hinges and initial lengths), against
the pose it truly takes, in the base frame (the reference nests'): its origin's error x, y, z
(um) and its turn about x, y, z (um/m, that is urad: see below). One trial draws a machine as the
scenario does (:func:`~calibench.scenarios.stewart.scenario.prior`, the hinges' and lengths'
errors drawn by the twin), records the scenario's one-step experiment (the tracker's stations
from the nests, its lengths to three reflectors and the legs' readings at ``config.n_poses``
random poses: MuJoCo's kinematics, nothing rendered), calibrates it as ``run`` does (the
per-leg pipeline, then the joint adjustment) and commands the grid. Where the machine goes is
the twin's own: the pose at which its legs (MuJoCo's slides, set by the twin's closed-form
inverse kinematics) have the commanded lengths, found by Newton on the twin's lengths, never by
the estimator's forward kinematics. The drives reach their readings exactly: a servo's own
scatter is the machine's repeatability, not its calibration's uncertainty.

One unit for the six: the driver states a task in one unit. ISO 230-1 states a machine's
angular errors in um/m, the displacement a turn causes a metre away, numerically its urad: the
turns are stated so (``rx`` 3.0 is a turn of 3 urad, 0.9 um at the platform's 300 mm hinge
radius), and a tolerance given in um reads as a tolerance in urad for them.

The GUM framework's answer beside it: the joint adjustment's covariance of the 42 leg
parameters (the reference machine's, the study's seed) propagated to each grid pose by the
task's Jacobian, about a mean error of zero::

    u(e_g)^2 = J_g C J_g^T,    J_g = A_g^-1 D_g

with A_g the legs' lengths' derivative with respect to the pose (a left turn omega and a shift)
and D_g theirs with respect to the calibrated parameters, both at the commanded pose: a
parameter's error changes the commanded lengths by D_g dp, and the machine then moves by
A_g^-1 of that.

The reference machine's covariance is one machine's: each machine is calibrated at its own 60
random poses (the scenario's procedure), and the GUM u of one machine differs from another's by
about 10 % (one std); the Monte Carlo's u is the machines' together. The GUM framework is
therefore validated (JCGM 101 8) only where that 10 % is within the numerical tolerance: at the
turns (u ~2 um/m, delta 0.5) mostly, at the origin's x (u just under 1 um, delta 0.05) seldom.
Those x quantities also set the adaptive stop: delta is 5-7 % of their u, which 200-trial
batches' endpoints reach after about 60 batches. A trial costs ~0.06-0.09 s on one core (the
recording's 60 poses ~0.02 s, the joint adjustment ~0.04 s, the grid's Newton ~0.01 s).
"""

from __future__ import annotations

import numpy as np

from calibench.estimators.rotations import matrix_to_rotvec, rotvec_to_matrix, rotvecs_to_matrices
from calibench.estimators.stewart.kinematics import leg_derivatives
from calibench.estimators.stewart.tracker import CONVERGED_STEP
from calibench.scenarios.stewart.scenario import (
    StewartConfig,
    joint_calibration,
    leg_array,
    measure_stations,
    one_step_data,
    prior,
)
from calibench.sim.stewart import StewartSim

# The grid: home and eight poses 100 sqrt(3) mm from it, 45 degrees below or above its level:
# four below (a square's corners) and four above (that square turned by 45 degrees), so that no
# two share a place on the map seen from above; each turned by 5 degrees towards where it is.
# Inside the calibration's poses (their shift +-150 mm, their turn +-10 degrees a component): a
# calibration is used where it was measured, and the grid's rim is where its errors grow most.
GRID_REACH_MM = 100.0 * np.sqrt(3)
GRID_TURN_DEG = 5.0
QUANTITIES = ("x", "y", "z", "rx", "ry", "rz")  # the origin's shift, then the turn, per pose
TO_UM = 1000.0  # mm -> um
TO_UM_PER_M = 1e6  # rad -> um/m (urad)
TASK = "compensated pose error of the platform: origin x, y, z (um), turns (um/m = urad)"
UNIT = "um"


def grid(config: StewartConfig) -> tuple[np.ndarray, np.ndarray]:
    """The task's commanded poses (G, 6): each a rotation vector (rad) then the origin (mm),
    and their origins (G, 3) mm (where the map puts them); G = 9, home first."""
    home = np.array([0.0, 0.0, config.geometry.home_height_mm])
    below = [(np.cos(a), np.sin(a), -1.0) for a in np.deg2rad([45, 135, 225, 315])]
    above = [(np.cos(a), np.sin(a), 1.0) for a in np.deg2rad([0, 90, 180, 270])]
    ways = np.array(below + above) / np.sqrt(2)  # unit vectors, 45 degrees off the level
    turns = np.r_[np.zeros((1, 3)), np.deg2rad(GRID_TURN_DEG) * ways]
    origins = home + np.r_[np.zeros((1, 3)), GRID_REACH_MM * ways]
    return np.c_[turns, origins], origins


def labels(points_mm: np.ndarray) -> list[dict]:
    """Each quantity's place and name, (6 G) in the order of :func:`trial`'s values."""
    return [
        {"at": {f"{a}_mm": round(float(v), 1) for a, v in zip("xyz", p)}, "quantity": q}
        for p in points_mm
        for q in QUANTITIES
    ]


def commanded(poses: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The grid's poses (G, 6) as R (G, 3, 3) and t (G, 3) mm."""
    return rotvecs_to_matrices(poses[:, :3]), poses[:, 3:]


def calibrated(config: StewartConfig, seed: int):
    """A machine drawn by ``seed`` and its one-step calibration, as the scenario's ``run`` draws
    and fits it; returns (sim, model (r (6, 3), B (6, 3), l (6,)) mm, the JointCalibration)."""
    rng = np.random.default_rng(seed)
    drawn = prior(config, rng)
    sim = StewartSim(drawn.geometry, drawn.truth, np.random.default_rng(rng.integers(2**63)))
    stations, _, nest_lengths = measure_stations(sim, drawn)
    data = one_step_data(sim, rng, drawn, stations)
    _, legs, joint, _ = joint_calibration(sim, drawn, stations, nest_lengths, data)
    if not joint.converged:  # its last iterate would pass for a calibration
        raise RuntimeError(f"seed {seed}: the joint adjustment did not converge")
    return sim, leg_array(legs), joint


def commanded_readings(model, R: np.ndarray, t: np.ndarray) -> np.ndarray:
    """The legs' readings (G, 6) mm that put the platform at poses R (G, 3, 3), t (G, 3) mm by
    the ``model`` (r, B, l): inverse kinematics, |R r + t - B| - l."""
    r, B, l = model
    return np.linalg.norm(np.einsum("gij,kj->gki", R, r) + t[:, None] - B, axis=2) - l


def reached(sim: StewartSim, readings: np.ndarray, R0: np.ndarray, t0: np.ndarray):
    """Where the twin goes with its legs at ``readings`` (G, 6) mm: per pose, Newton from (R0,
    t0) (G, 3, 3), (G, 3) on the twin's own lengths (MuJoCo's slides) to reading + its true
    initial length; returns R (G, 3, 3), t (G, 3) mm."""
    R_out, t_out = np.empty_like(R0), np.empty_like(t0)
    for g, (R, t) in enumerate(zip(R0, t0)):
        want = readings[g] + sim.l0
        for _ in range(20):
            sim.set_pose(R, t)
            arm = sim.r @ R.T
            v = arm + t - sim.B
            u = v / np.linalg.norm(v, axis=1)[:, None]
            # the step's direction only: its residual is the twin's, so the answer is the twin's
            step = np.linalg.solve(np.c_[np.cross(arm, u), u], want - sim.leg_lengths_mm())
            R, t = rotvec_to_matrix(step[:3]) @ R, t + step[3:]
            if np.max(np.abs(step)) < 1e-12:
                break
        if np.max(np.abs(step)) > CONVERGED_STEP:
            raise RuntimeError("the twin's pose for the commanded legs did not converge")
        R_out[g], t_out[g] = R, t
    return R_out, t_out


def pose_errors(sim: StewartSim, model, poses: np.ndarray) -> np.ndarray:
    """The twin's pose error (6 G,) at the grid's ``poses`` (G, 6) commanded through ``model``
    (r, B, l): per pose its origin's shift (um), then its turn (um/m), base frame."""
    Rc, tc = commanded(poses)
    R, t = reached(sim, commanded_readings(model, Rc, tc), Rc, tc)
    turn = matrix_to_rotvec(np.einsum("gij,gkj->gik", R, Rc)).reshape(-1, 3)
    return np.c_[(t - tc) * TO_UM, turn * TO_UM_PER_M].ravel()


def trial(config: StewartConfig, poses: np.ndarray, seed: int) -> np.ndarray:
    """One trial's compensated pose errors (6 G,): a machine drawn by ``seed``, calibrated,
    commanded to the grid's ``poses`` (G, 6) through its calibration."""
    sim, model, _ = calibrated(config, seed)
    return pose_errors(sim, model, poses)


def gum(config: StewartConfig, poses: np.ndarray, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """The GUM framework's inputs: the task's Jacobian (6 G, 42) (um or um/m per mm, at the
    reference machine's calibration) and that calibration's covariance (42, 42) mm^2 (legs
    a, b, c, m, n, q, l each)."""
    _, model, joint = calibrated(config, seed)
    return task_jacobian(model, poses), joint.cov


def task_jacobian(model, poses: np.ndarray) -> np.ndarray:
    """d(pose error at each grid pose) / d(the 42 leg parameters r, B, l per leg), (6 G, 42),
    um (shift) and um/m (turn) per mm, at ``model`` (r, B, l) mm and the grid's ``poses`` (G,
    6): A^-1 D per pose (the module's docstring), rows shift then turn."""
    r, B, _ = model
    Rc, tc = commanded(poses)
    arm = np.einsum("gij,kj->gki", Rc, r)
    v = arm + tc[:, None] - B
    u = v / np.linalg.norm(v, axis=2)[..., None]
    A = np.concatenate([np.cross(arm, u), u], axis=2)  # (G, 6 legs, omega then t)
    D = np.zeros((len(poses), 6, 42))
    blocks = leg_derivatives(Rc, u)  # (G, 6, 7): d(a leg's commanded length) / d(its seven)
    for i in range(6):
        D[:, i, 7 * i : 7 * i + 7] = blocks[:, i]
    dpose = np.linalg.solve(A, D)  # (G, 6: omega then t, 42)
    scale = np.r_[np.full(3, TO_UM), np.full(3, TO_UM_PER_M)][:, None]
    return (np.concatenate([dpose[:, 3:], dpose[:, :3]], axis=1) * scale).reshape(-1, 42)
