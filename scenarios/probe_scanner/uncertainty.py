"""The probe scanner's task-specific uncertainty: the traced rim's compensated radius around the
turn.

The task: the frame tracer, calibrated on its plate, traces the spectacle rim; at each of
:data:`GRID_ANGLES` places around the rim (holder polar angles phi_g about the table's axis) its
compensated contour point P = d n + (dL + rho) u (the calibration's d, dL, alpha0) has a radius
|P| at a polar angle phi_c; the error is |P| less the rim's true radius at phi_c (um). A radius
judged at the point's own angle is the traced outline's radial error: it holds the alpha0 error
(a turned outline is off in radius by the rim's slope dR/dphi times the turn) as well as d's and
dL's. One trial draws a machine from the scenario's prior (d, dL, alpha0, the plate's centre),
records one turn of the plate (1600 samples, MuJoCo's rays with the probe's noise and the
encoder's quantum, as the scenario's), calibrates it as the scenario's fit does (the paper's four
minima as the start, the full-data least squares as the answer) and reads the rim at the encoder
angle where the stylus touches it at phi_g. That reading is exact (no probe noise, no quantum):
the error is the calibration's alone, as the arm's and the stage's tasks have it. The truth is
MuJoCo's too: the rim's walls along phi_c from the table's axis
(:meth:`~calibench.sim.probe_scanner.ProbeScannerSim.radius_mm`), the chords the stylus meets.

The GUM framework's answer beside it: the full-data calibration's covariance of (d, dL, alpha0,
cx, cy) as its estimator states it (a reference machine's, the study's seed), propagated by the
task's Jacobian at that machine's rim readings, about a mean error of zero::

    u(e_g)^2 = J_g C J_g^T,   J_g = (d/R - R' s/R^2, s/R + R' d/R^2, -R', 0, 0)

with s = dL + rho, R = |P| and R' the rim's slope dR/dphi at phi_c (the plate's centre does not
move the rim's trace: its columns are zero). R' is the exact curve's (smooth, no chord's end
in its way): the walls' own slopes, which the trial sees, differ from it by under 0.08 mm/rad
(720 angles), under 5 nm through alpha0's 40-60 urad, in quadrature with u of 60 nm or more.

A trial costs about 65 ms of CPU: the twin written into the design's compiled model
(:func:`~calibench.scenes.probe_scanner.as_built_model`), the plate's 1600 rays, the least
squares (half of it), 48 rays at the rim.
"""

from __future__ import annotations

import functools

import numpy as np

from calibench.estimators.probe_scanner.calibration import (
    ScannerCalibration,
    calibrate_lsq,
    calibrate_paper,
    contour_points,
)
from calibench.scenarios.probe_scanner.scenario import ProbeScannerConfig, prior
from calibench.sim.probe_scanner import ProbeScannerSim

GRID_ANGLES = 24  # places around the rim, every 15 degrees
OUTLINE_POINTS = 40_000  # the exact rim's dense outline, for its polar radius and slope
SLOPE_STEP_RAD = 1e-3  # the slope's central difference: many outline points wide
TASK = "compensated radius of the traced rim about the table's axis, along its polar angle"
UNIT = "um"


def grid(config: ProbeScannerConfig) -> tuple[np.ndarray, np.ndarray]:
    """The task's places: polar angles (G,) rad about the table's axis, every 360 / G degrees,
    and the rim's points there (G, 3) mm (z = 0; the exact curve's radius)."""
    phi = np.arange(GRID_ANGLES) * 2 * np.pi / GRID_ANGLES
    r = rim_radius_mm(config.geometry.lens, phi)
    return phi, np.c_[r * np.cos(phi), r * np.sin(phi), np.zeros(len(phi))]


def labels(points_mm: np.ndarray) -> list[dict]:
    """Each quantity's place and name, (G) in the order of :func:`trial`'s values."""
    return [
        {
            "at": {
                "angle_deg": round(float(np.degrees(np.arctan2(p[1], p[0]))) % 360, 1),
                "r_mm": round(float(np.hypot(p[0], p[1])), 2),
            },
            "quantity": "radius",
        }
        for p in points_mm
    ]


@functools.lru_cache(maxsize=4)
def _rim_polar(lens) -> tuple[np.ndarray, np.ndarray]:
    """The exact rim's polar angle (n,) rad, ascending, and radius (n,) mm about the table's
    axis (the rim is convex about it: one radius per angle)."""
    xy = lens.outline(n=OUTLINE_POINTS)
    phi = np.arctan2(xy[:, 1], xy[:, 0])
    order = np.argsort(phi)
    return phi[order], np.hypot(xy[order, 0], xy[order, 1])


def rim_radius_mm(lens, phi_rad: np.ndarray) -> np.ndarray:
    """The exact rim's radius (n,) mm at polar angles (n,) rad (its dense outline, linearly
    between points under a micrometre apart)."""
    ph, r = _rim_polar(lens)
    return np.interp(np.asarray(phi_rad, float), ph, r, period=2 * np.pi)


def rim_slope(lens, phi_rad: np.ndarray) -> np.ndarray:
    """The exact rim's dR/dphi (n,) mm/rad at polar angles (n,) rad: a central difference over
    :data:`SLOPE_STEP_RAD` (the outline's linear pieces' kinks average out, the curve's third
    derivative stays under 1e-5 of it)."""
    h = SLOPE_STEP_RAD
    phi = np.asarray(phi_rad, float)
    return (rim_radius_mm(lens, phi + h) - rim_radius_mm(lens, phi - h)) / (2 * h)


def radius_error_mm(
    theta_rad: np.ndarray, rho_mm: np.ndarray, params: np.ndarray, radius
) -> np.ndarray:
    """The traced rim's radial error (n,) mm: the contour point of samples (theta, rho) (n,)
    by ``params`` (d, dL, alpha0, ...) mm, rad, its radius less ``radius(phi)`` (a callable,
    the true radius (n,) mm at polar angles (n,)) at its own polar angle phi."""
    p = contour_points(theta_rad, rho_mm, params[0], params[1], params[2])
    return np.hypot(p[:, 0], p[:, 1]) - radius(np.arctan2(p[:, 1], p[:, 0]))


def task_jacobian(
    theta_rad: np.ndarray, rho_mm: np.ndarray, params: np.ndarray, slope
) -> np.ndarray:
    """d(:func:`radius_error_mm`) / d(d, dL, alpha0, cx, cy), (n, 5) mm per mm, mm, rad, mm,
    mm, for samples (n,), (n,) at ``params``; ``slope(phi)`` is the true rim's dR/dphi (n,)."""
    d, dL, alpha0 = params[0], params[1], params[2]
    s = dL + np.asarray(rho_mm, float)
    R2 = d * d + s * s
    R = np.sqrt(R2)
    rp = slope(alpha0 + np.asarray(theta_rad, float) + np.arctan2(d, s))
    # |P| moves by (d, s) / R; its polar angle by (s, -d) / R^2 and 1 for alpha0, the true
    # radius there by the rim's slope times that
    J = np.zeros((len(s), 5))
    J[:, 0] = d / R - rp * s / R2
    J[:, 1] = s / R + rp * d / R2
    J[:, 2] = -rp
    return J


def parameters(cal: ScannerCalibration) -> np.ndarray:
    """A calibration's (d, dL, alpha0, cx, cy) (5,) mm, rad: the covariance's order."""
    return np.r_[cal.d_mm, cal.dL_mm, cal.alpha0_rad, cal.centre_mm]


def traced(config: ProbeScannerConfig, phi_rad: np.ndarray, seed: int):
    """A machine drawn by ``seed``, calibrated on one simulated turn of the plate, and its exact
    rim readings where the stylus touches the rim at ``phi_rad`` (G,).

    Returns (sim, drawn config, calibration, encoder angles (G,) rad, readings (G,) mm)."""
    rng = np.random.default_rng(seed)
    drawn = prior(config, rng)
    sim = ProbeScannerSim(drawn.geometry, drawn.truth)
    plate, _ = sim.scan("plate", rng)
    a, r = drawn.geometry.plate.half_side_mm, drawn.geometry.plate.corner_radius_mm
    start = calibrate_paper(
        plate.theta_rad, plate.rho_mm, config.paper_m, a, config.nominal.alpha0_rad
    )
    cal = calibrate_lsq(plate.theta_rad, plate.rho_mm, a, r, start)
    # the stylus meets the rim at phi where the rail's line, d from the axis, crosses it:
    # sqrt(R^2 - d^2) along the rail, at a polar angle atan2(d, that) ahead of the rail's
    t = drawn.truth
    phi = np.asarray(phi_rad, float)
    along = np.sqrt(sim.radius_mm("lens", phi) ** 2 - t.d_mm**2)
    theta = phi - t.alpha0_rad - np.arctan2(t.d_mm, along)
    return sim, drawn, cal, theta, sim.reading_mm("lens", theta)


def trial(config: ProbeScannerConfig, phi_rad: np.ndarray, seed: int) -> np.ndarray:
    """One trial's compensated radius errors (G,) um: the calibrated trace's radius at each
    grid place less the rim's true radius (MuJoCo's walls) at the trace's polar angle."""
    sim, _, cal, theta, rho = traced(config, phi_rad, seed)
    return 1000 * radius_error_mm(
        theta, rho, parameters(cal), functools.partial(sim.radius_mm, "lens")
    )


def gum(
    config: ProbeScannerConfig, phi_rad: np.ndarray, seed: int
) -> tuple[np.ndarray, np.ndarray]:
    """The task's Jacobian (G, 5) um per (mm, mm, rad, mm, mm) at the reference machine's
    calibration and rim readings, and that calibration's covariance (5, 5) as its estimator
    states it."""
    _, drawn, cal, theta, rho = traced(config, phi_rad, seed)
    if cal.cov is None:
        raise RuntimeError("the full-data calibration returned no covariance")
    lens = drawn.geometry.lens
    J = task_jacobian(theta, rho, parameters(cal), functools.partial(rim_slope, lens))
    return 1000 * J, cal.cov
