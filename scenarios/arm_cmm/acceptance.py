"""The standards' acceptance tests run on the arm's twin, before and after its calibration.

- ISO 9283:1998 (an arm used as a robot): pose accuracy ``AP`` and repeatability ``RP`` of the
  position at the standard's five poses, visited in cycles P1 .. P5, 30 of them. The poses lie
  on the cube's diagonal plane (C1-C2-C7-C8): P1 the cube's centre, P2-P5 on the diagonals at a
  tenth of their length from the corners (clause 6.8). For each pose, the mean attained point's
  distance from the commanded one is AP; the attained points' mean distance from their
  barycentre plus three of its standard deviations is RP (clauses 7.2.1, 7.2.2). A laser
  tracker reads a point, not an orientation: the orientation's figures are not simulated.
- ISO 10360-12:2016 (an articulated-arm CMM): the length measurement error ``E_UNI`` of a
  calibrated bar measured end to end in positions and orientations over the workspace, the
  articulated location test ``L_Dia`` (a ball seated in one cone, the arm articulated through
  different postures: twice the largest distance of the measured centres from their mean), and
  the probing errors ``P_Size`` and ``P_Form`` of a reference sphere probed at 25 points (the
  fitted diameter's error, the range of the radial residuals).

The twin is the machine: MuJoCo's body chain with the as-built errors and the links' sag under
gravity, its encoders and tracker with their noise (``sim.arm_cmm``). A robot's commanded joint
angles come from its controller's model (inverse kinematics of the nominal arm before
calibration, of the calibrated one after), the robot reaches them within its servo's scatter and
the twin says where its tool went; an arm CMM is moved by hand onto a target (inverse kinematics
on MuJoCo's own Jacobian) and reports the point its model makes of its encoders' readings.
Before calibration the model is the drawing, its frame and tool registered on the calibration
recording; after, ``fit``'s calibration of that recording. Units: mm and rad inside, um in the
report (AP and RP in mm, as the standard states them for robots).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from calibench.estimators.arm.calibration import calibrate
from calibench.estimators.arm.kinematics import Chain, point
from calibench.estimators.rotations import rigid_transform
from calibench.scenarios.arm_cmm.arms import chain_of
from calibench.scenarios.arm_cmm.scenario import ArmCmmConfig, prior
from calibench.scenarios.report import BadInput
from calibench.sim.arm_cmm import ArmSim

CYCLES = 30  # ISO 9283 clause 7.2: 30 cycles through the five poses
CALIBRATION_POSTURES = 200  # the tracker recording the arm is calibrated on
CUBE_SHARE = 0.3  # the cube's side as a share of the arm's reach: well inside its workspace


@dataclasses.dataclass
class Models:
    """The arm's model before and after calibration: ``base_points(name, q) -> (n, 3)`` mm in its
    base frame, and each one's base-to-tracker frame ``frames[name] = (R, t)``."""

    chain: Chain
    cal: object
    frames: dict

    def base_points(self, which: str, q_rad: np.ndarray) -> np.ndarray:
        """The model ``which`` (``before``, ``after``) at postures (n, N), mm, its base frame."""
        q = np.atleast_2d(q_rad)
        if which == "before":
            return point(self.chain, q)
        return self.cal.problem.base_points(self.cal.state, q)  # type: ignore[attr-defined]


def tracker_xyz(sim: ArmSim, q_motor: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """The tracker's reading of the tool point (n, 3) mm, Cartesian in its own frame."""
    r, az, el = sim.tracker(q_motor, rng).T
    return np.stack([r * np.cos(el) * np.cos(az), r * np.cos(el) * np.sin(az), r * np.sin(el)], 1)


def twin_and_models(config: ArmCmmConfig, seed: int) -> tuple[ArmSim, Models, dict]:
    """The machine (its errors drawn from the as-built distribution by ``seed``), and its model
    before and after calibration on a simulated tracker recording of
    :data:`CALIBRATION_POSTURES` random postures (its readings the encoders', its points the
    tracker's). Returns the twin, the models and what the calibration was."""
    rng = np.random.default_rng(seed)
    drawn = prior(config, rng)
    sim = ArmSim(drawn.arm, drawn.truth)
    chain = chain_of(sim.arm)
    q = sim.random_postures(CALIBRATION_POSTURES, rng)
    xyz = tracker_xyz(sim, q, rng)
    read = sim.encoders(q, rng)
    model = "physics" if chain.has_masses else "geometry"
    cal = calibrate(chain, read, xyz, np.zeros(len(q), int), None, model)
    R0, t0 = rigid_transform(point(chain, read), xyz)  # the drawing, its frame registered
    frames = {"before": (R0, t0), "after": (cal.state.R[0], cal.state.t[0])}
    said = {
        "postures": CALIBRATION_POSTURES,
        "model": model,
        "parameters": len(cal.ident.basis.kept),
        "seed": seed,
    }
    return sim, Models(chain, cal, frames), said


def inverse_kinematics(
    models: Models, which: str, target_mm: np.ndarray, q0: np.ndarray, iterations: int = 50
) -> np.ndarray:
    """The controller's joint angles (N,) putting model ``which``'s tool point at ``target_mm``
    (3,) in its base frame: damped least squares from ``q0`` (N,), the Jacobian by central
    differences of the model (the least-norm step keeps the redundant joints near ``q0``)."""
    q = np.asarray(q0, float).copy()
    h = 1e-7
    for _ in range(iterations):
        err = target_mm - models.base_points(which, q)[0]
        if np.linalg.norm(err) < 1e-9:
            break
        steps = np.vstack([q + h * e for e in np.eye(len(q))] + [q - h * e for e in np.eye(len(q))])
        p = models.base_points(which, steps)
        J = ((p[: len(q)] - p[len(q) :]) / (2 * h)).T  # (3, N) mm / rad
        q = q + J.T @ np.linalg.solve(J @ J.T + 1e-10 * np.eye(3), err)
    return q


def iso9283_poses(sim: ArmSim, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """The five poses' points (5, 3) mm in the base frame and a posture (5, N) near each: a cube
    of side :data:`CUBE_SHARE` of the reach about a posture's tool point, P1 its centre, P2-P5 a
    tenth of the diagonal of the plane C1-C2-C7-C8 in from its corners (ISO 9283 clause 6.8.3)."""
    side = CUBE_SHARE * sim.arm.reach_mm
    for _ in range(200):
        centre = sim.random_postures(1, rng)[0]
        c = sim.probe_mm(centre)[0]
        # the diagonal plane through the cube's bottom front edge and top back edge
        corners = c + side / 2 * np.array([[-1, -1, -1], [1, -1, -1], [1, 1, 1], [-1, 1, 1]])
        points = np.vstack([c, c + 0.8 * (corners - c)])
        try:
            postures = np.vstack([sim.postures_in_cone(p, 1, rng) for p in points])
        except BadInput:  # a corner out of reach: another centre
            continue
        return points, postures
    raise RuntimeError(f"no cube of side {side:.0f} mm found in the arm's reach")


def pose_figures(
    attained_mm: np.ndarray, commanded_mm: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """ISO 9283's position accuracy and repeatability of each pose (clauses 7.2.1, 7.2.2)::

        AP = |mean_j x_j - x_c|,    RP = l_mean + 3 S_l,    l_j = |x_j - mean x|

    with S_l the standard deviation of the l_j (n - 1). ``attained_mm`` (cycles, poses, 3),
    ``commanded_mm`` (poses, 3); returns AP and RP, (poses,) each."""
    mean = attained_mm.mean(axis=0)
    l_j = np.linalg.norm(attained_mm - mean, axis=2)
    return np.linalg.norm(mean - commanded_mm, axis=1), l_j.mean(axis=0) + 3 * l_j.std(
        axis=0, ddof=1
    )


def iso9283(config: ArmCmmConfig, seed: int) -> dict:
    """ISO 9283's position accuracy and repeatability at its five poses, before and after."""
    sim, models, said = twin_and_models(config, seed)
    rng = np.random.default_rng(seed + 1)
    points, postures = iso9283_poses(sim, rng)
    R_true, t_true = sim.base2tracker()
    targets = points @ R_true.T + t_true  # commanded in the tracker's frame
    servo = sim.truth.encoder_noise_urad * 1e-6  # the servo reaches its angle within this
    out: dict = {}
    for which in ("before", "after"):
        R, t = models.frames[which]
        q_cmd = np.array(
            [
                inverse_kinematics(models, which, R.T @ (g - t), q0)
                for g, q0 in zip(targets, postures)
            ]
        )
        reached = np.repeat(q_cmd[None], CYCLES, 0) + rng.normal(0, servo, (CYCLES, *q_cmd.shape))
        attained = tracker_xyz(sim, reached.reshape(-1, q_cmd.shape[1]), rng).reshape(CYCLES, 5, 3)
        AP, RP = pose_figures(attained, targets)
        out[which] = {
            "AP_mm": float(AP.max()),
            "RP_mm": float(RP.max()),
            "per_pose": [
                {"pose": f"P{k + 1}", "AP_mm": float(a), "RP_mm": float(r)}
                for k, (a, r) in enumerate(zip(AP, RP))
            ],
        }
    side = CUBE_SHARE * sim.arm.reach_mm
    out["procedure"] = (
        f"ISO 9283 position accuracy and repeatability: a cube of {side:.0f} mm side, P1 its "
        "centre, P2-P5 on the diagonal plane C1-C2-C7-C8 a tenth of the diagonal in from the "
        f"corners; {CYCLES} cycles P1..P5; the commanded joint angles from the controller's "
        "model (the drawing before, the calibration after), reached within the servo's "
        f"{sim.truth.encoder_noise_urad:g} urad per joint, read by the laser tracker; the "
        f"calibration: {said['postures']} random postures ({said['model']} model). Position "
        "only: a tracker reads no orientation."
    )
    out["calibration"] = said
    return out
