"""ISO 10360-12's tests of an articulated-arm CMM, run on the twin before and after calibration
(:mod:`.acceptance` says how the machine and its models are made).

- ``E_UNI``: a calibrated bar of each of :data:`BAR_SHARES` of the reach, in
  :data:`BAR_POSITIONS` positions and orientations drawn over the workspace, its two ends probed:
  the largest error of the measured length (clause 6.3).
- ``L_Dia``: the articulated location test, a ball seated :data:`LOCATIONS` times in one cone
  from postures drawn anew: twice the largest distance of the measured centres from their mean
  (clause 6.4's diameter of the points' spread).
- ``P_Size``, ``P_Form``: a reference sphere of :data:`SPHERE_MM` probed at 25 points (its pole,
  then rings of 8 at 60, 30 and 0 deg of elevation): the error of the least-squares sphere's
  diameter and the range of the points' radial distances from its centre (clause 6.2).

The arm is moved by hand onto each target (inverse kinematics on MuJoCo's Jacobian, the ball's
seating scattering as the truth says); the encoders read its posture with their noise and the
model before (the drawing) and after (the calibration) makes a point of that one reading, so
both answer for the same measurements.
"""

from __future__ import annotations

import numpy as np

from calibench.scenarios.arm_cmm.acceptance import twin_and_models
from calibench.scenarios.arm_cmm.scenario import ArmCmmConfig
from calibench.scenarios.report import BadInput
from calibench.sim.arm_cmm import ArmSim

SPHERE_MM = 25.0  # the reference sphere's diameter, the probe ball's centre on it
LOCATIONS = 20  # seatings in the articulated location test's cone
BAR_SHARES = (0.15, 0.3, 0.6)  # the bar's lengths, shares of the reach
BAR_POSITIONS = 7  # positions and orientations of each length
DRAWS = 200  # tries to place an artefact within reach


def seated(sim: ArmSim, targets_mm: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """A posture (n, N) with the probe on each target (n, 3) mm, or BadInput if one is out of
    reach."""
    return np.vstack([sim.postures_in_cone(t, 1, rng) for t in targets_mm])


def placed(sim: ArmSim, rng: np.random.Generator, shape) -> tuple[np.ndarray, np.ndarray]:
    """An artefact's probed points ``shape(centre, rng) -> (k, 3)`` about a reachable centre,
    and the postures that reach them: redrawn until the arm reaches every point."""
    for _ in range(DRAWS):
        centre = sim.probe_mm(sim.random_postures(1, rng))[0]
        points = shape(centre, rng)
        try:
            return points, seated(sim, points, rng)
        except BadInput:
            continue
    raise BadInput(f"the arm {sim.arm.name} reaches no placing of an artefact in {DRAWS} draws")


def sphere_directions() -> np.ndarray:
    """25 unit vectors (25, 3): the pole, then rings of 8 at 60, 30 and 0 deg of elevation."""
    rings = [np.array([[0.0, 0.0, 1.0]])]
    for el in np.radians([60.0, 30.0, 0.0]):
        az = np.arange(8) * np.pi / 4 + el  # each ring turned against the one above
        rings.append(
            np.stack([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.full(8, np.sin(el))], 1)
        )
    return np.vstack(rings)


def fitted_sphere(p_mm: np.ndarray) -> tuple[np.ndarray, float]:
    """The least-squares sphere through points (n, 3): its centre (3,) and radius, from the
    linear model |p|^2 = 2 c . p + (r^2 - |c|^2), then Gauss-Newton on the distances."""
    A = np.c_[2 * p_mm, np.ones(len(p_mm))]
    sol = np.linalg.lstsq(A, np.sum(p_mm**2, axis=1), rcond=None)[0]
    c = sol[:3]
    r = float(np.sqrt(sol[3] + c @ c))
    for _ in range(10):
        d = p_mm - c
        dist = np.linalg.norm(d, axis=1)
        J = np.c_[-d / dist[:, None], -np.ones(len(d))]
        step = np.linalg.lstsq(J, -(dist - r), rcond=None)[0]
        c, r = c + step[:3], r + float(step[3])
    return c, r


def figures(
    bars_mm: np.ndarray, ends_mm: np.ndarray, centres_mm: np.ndarray, probed_mm: np.ndarray
) -> dict:
    """The test's figures (um) from what the arm measured.

    Parameters
    ----------
    bars_mm : ndarray, (B,)
        Each bar's calibrated length.
    ends_mm : ndarray, (B, 2, 3)
        Each bar's two ends as the arm measured them.
    centres_mm : ndarray, (L, 3)
        The ball's centre in its cone, measured from each of the L postures.
    probed_mm : ndarray, (K, 3)
        The points probed on the test sphere (diameter :data:`SPHERE_MM`).

    Returns
    -------
    dict
        E_UNI = max |measured - calibrated length|; L_Dia = twice the largest distance of a
        location from their mean (the diameter of the sphere about the mean that holds them);
        P_Size = the least-squares sphere's diameter less the sphere's; P_Form = the range of
        the points' radial distances from that sphere's centre; and each bar's error.
    """
    errors = np.linalg.norm(ends_mm[:, 1] - ends_mm[:, 0], axis=1) - bars_mm
    spread = np.linalg.norm(centres_mm - centres_mm.mean(axis=0), axis=1)
    c, r = fitted_sphere(probed_mm)
    radial = np.linalg.norm(probed_mm - c, axis=1)
    return {
        "E_UNI_um": 1000 * float(np.abs(errors).max()),
        "L_Dia_um": 1000 * float(2 * spread.max()),
        "P_Size_um": 1000 * float(2 * r - SPHERE_MM),
        "P_Form_um": 1000 * float(np.ptp(radial)),
        "length_errors_um": (1000 * errors).round(2).tolist(),
    }


def iso10360_12(config: ArmCmmConfig, seed: int) -> dict:
    """E_UNI, L_Dia, P_Size and P_Form of the arm CMM before and after its calibration (um)."""
    sim, models, said = twin_and_models(config, seed)
    rng = np.random.default_rng(seed + 2)
    reach = sim.arm.reach_mm
    bars, bar_q = [], []
    for share in BAR_SHARES:
        L = share * reach
        for _ in range(BAR_POSITIONS):

            def bar(centre, rng, L=L):
                u = rng.normal(size=3)
                u /= np.linalg.norm(u)
                return centre + np.outer([-0.5, 0.5], L * u)

            ends, q = placed(sim, rng, bar)
            bars.append(float(np.linalg.norm(ends[1] - ends[0])))
            bar_q.append(q)
    cone, cone_q = placed(sim, rng, lambda c, rng: c[None])
    cone_q = sim.postures_in_cone(cone[0], LOCATIONS, rng)
    radius = SPHERE_MM / 2
    ball, ball_q = placed(sim, rng, lambda c, rng: c + radius * sphere_directions())
    read = {
        "bar": sim.encoders(np.vstack(bar_q), rng),
        "cone": sim.encoders(cone_q, rng),
        "ball": sim.encoders(ball_q, rng),
    }
    out: dict = {}
    for which in ("before", "after"):
        out[which] = figures(
            np.array(bars),
            models.base_points(which, read["bar"]).reshape(-1, 2, 3),
            models.base_points(which, read["cone"]),
            models.base_points(which, read["ball"]),
        )
    lengths = ", ".join(f"{s * reach:.0f}" for s in BAR_SHARES)
    out["procedure"] = (
        f"ISO 10360-12: E_UNI over bars of {lengths} mm, each in {BAR_POSITIONS} positions and "
        f"orientations drawn over the workspace, both ends probed; L_Dia from {LOCATIONS} "
        f"seatings of the ball in one cone from postures drawn anew; P_Size and P_Form from a "
        f"{SPHERE_MM:g} mm sphere probed at 25 points (the pole and rings of 8 at 60, 30 and 0 "
        "deg). Each target reached by hand on the twin (its seating scattering "
        f"{sim.truth.cone_seat_um:g} um), read by the encoders ({sim.truth.encoder_noise_urad:g} "
        "urad), the point made by the drawing before and by the calibration after (on "
        f"{said['postures']} tracker postures, {said['model']} model)."
    )
    out["calibration"] = said
    return out
