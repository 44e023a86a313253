"""The vision stage's task-specific uncertainty: the table's compensated position error.

The task: at each target of a grid over the range the plate calibrates, the table commanded
through the seed's cubic (:func:`~calibench.estimators.stage.compensation.compensated_command`)
and where it truly goes, x and y (um), relative to where it truly is at the reading the
calibration took as its zero (circle (0, 0)'s), in the frame whose x runs along the X motion:
the scenario's own truth (:func:`~calibench.scenarios.vision_stage.scenario.true_error_field`).

One trial draws a machine from the scenario's prior (the plate laid at a random angle; the
circles' manufacturing errors, the drives' scatter and the detector's noise from the trial's
seed), renders nothing (the analytic microscope: the exact image of each centre plus the
detector's noise), aligns the plate, servoes the 20 x 13 circles, aiming each where the circles
before it predict it as the rendered run does (one look a circle, mostly: half the analytic run's
looks, the same readings' statistics), fits the cubic of each axis as ``fit_plate`` does
(without its model selection, which the task does not use and which would add 0.1 s CPU to a
trial's 0.16 s) and commands the grid. Line rulers and the interferometer are left out: the task
does not use them.

The GUM framework's answer: both cubics' coefficients with the covariance of their least-squares
fit to points of the scatter the scenario reports (``point_scatter_um``), with the two errors
that reach every point at once entered as they enter the fit (:func:`coefficient_cov`): the
datum (each point's error is taken relative to circle (0, 0)'s reading, whose own error shifts
them all alike) and the alignment's angle (measured on two circles of the first row, whose own
errors turn the whole nominal grid). The scenario's reported ``cubic_std`` holds each coefficient
alone (the datum's share of a0 in quadrature) and adds the angle's error to the cross slopes as
if it were apart from the points' (it is made of two of them): with no correlation between the
coefficients, it nearly doubles the far targets' u in y. A 400-trial study's spread is this u
to 4 % at every grid point. It is propagated about a mean error of zero: the cubic's misfit of
the true field (the scales' periodic errors, which no cubic follows; up to 1.3 um) is the Monte
Carlo's mean, not in the GUM's interval, which is therefore not validated there (JCGM 101 8)
although its u is right.

The Jacobian is minus the monomials at each target's compensated command (the command moves
against the model's value; :func:`task_jacobian`)::

    u(e_g)^2 = a_g^T C a_g,    a_g = the cubics' monomials at command g less the origin
"""

from __future__ import annotations

import dataclasses

import numpy as np

from calibench.estimators.stage.circle_plate import fit_plate
from calibench.estimators.stage.compensation import (
    MONOMIAL_SCALE_MM,
    Polynomial,
    compensated_command,
    design,
    fit_polynomial,
    monomial_powers,
)
from calibench.scenarios.uncertainty import plane_labels
from calibench.scenarios.vision_stage.procedure import Microscope, align_plate
from calibench.scenarios.vision_stage.scenario import (
    VisionStageConfig,
    point_pairs,
    prior,
    true_error_field,
)
from calibench.sim.vision_stage import VisionStageSim

GRID = (4, 3)  # targets along x and y, inside the calibrated range's outer tenth
TASK = "compensated position error of the table (the plate's cubic), x and y"
UNIT = "um"
DEGREE = 3  # the seed's cubic (Eq. 5-9): the scenario's ``polynomial`` compensation
N_COEF = len(monomial_powers(DEGREE))


def calibrated_range(config: VisionStageConfig) -> tuple[np.ndarray, np.ndarray]:
    """The readings (2,) mm of the grid's first circle and of its last: what the plate
    calibrates (nominally; each machine's own readings differ by its errors, microns)."""
    g = config.geometry
    lo = np.asarray(g.plate_origin_reading_mm, float)
    return lo, lo + (np.asarray(config.grid) - 1) * g.plate.pitch_mm


def grid(config: VisionStageConfig) -> tuple[np.ndarray, np.ndarray]:
    """The task's targets (G, 2) mm over the calibrated range (the cubic is not asked where it
    extrapolates), and their points (G, 3) mm (z = 0)."""
    lo, hi = calibrated_range(config)
    xs = lo[0] + np.linspace(0.1, 0.9, GRID[0]) * (hi[0] - lo[0])
    ys = lo[1] + np.linspace(0.1, 0.9, GRID[1]) * (hi[1] - lo[1])
    targets = np.array([(x, y) for y in ys for x in xs])
    return targets, np.c_[targets, np.zeros(len(targets))]


def labels(points_mm: np.ndarray) -> list[dict]:
    """Each quantity's place and name, (2 G) in the order of :func:`trial`'s values."""
    return plane_labels(points_mm)


@dataclasses.dataclass(frozen=True)
class Calibration:
    """One machine's plate calibration: ``readings_mm`` (n, 2) and ``nominal_mm`` (n, 2) the
    point pairs (circle (0, 0) first), ``cubic`` each axis's model of the error at readings
    less ``origin_mm`` (2,), ``phi_residual_rad`` the plate's true angle to the X motion (the
    truth's frame), ``baseline_mm`` the distance between the alignment's two circles and
    ``far_index`` the far one's place among the points (the near one is point 0)."""

    readings_mm: np.ndarray
    nominal_mm: np.ndarray
    origin_mm: np.ndarray
    cubic: tuple[Polynomial, Polynomial]
    phi_residual_rad: float
    baseline_mm: float
    far_index: int

    def error_um(self, readings_mm: np.ndarray) -> np.ndarray:
        """The cubic's error (n, 2) um at readings (n, 2) mm: the scenario's ``polynomial``."""
        rel = np.atleast_2d(readings_mm) - self.origin_mm
        return np.stack([c(rel[:, 0], rel[:, 1]) for c in self.cubic], axis=1)


def plate_cubic(
    readings_mm: np.ndarray, nominal_mm: np.ndarray
) -> tuple[np.ndarray, tuple[Polynomial, Polynomial]]:
    """``fit_plate``'s cubic of each axis without its model selection: the origin (2,) mm and
    the two models (the same coefficients to the bit: a test holds them so)."""
    origin = readings_mm[0]
    rel = readings_mm - origin
    err_um = (nominal_mm - rel) * 1000  # true - reading, relative to circle (0, 0)
    fx, fy = (fit_polynomial(rel[:, 0], rel[:, 1], err_um[:, a], DEGREE) for a in range(2))
    return origin, (fx, fy)


def calibrated(config: VisionStageConfig, seed: int) -> tuple[VisionStageSim, Calibration]:
    """A machine drawn by ``seed`` (the scenario's prior), its plate aligned and measured with
    the analytic microscope and its cubic fitted; returns the simulator (the caller closes it)
    and the calibration."""
    rng = np.random.default_rng(seed)
    drawn = prior(config, rng)
    sim = VisionStageSim(
        drawn.geometry, drawn.truth, np.random.default_rng(rng.integers(2**63)), render=False
    )
    scope = Microscope(sim, drawn, "analytic")
    phi_est, phi_true, s00 = align_plate(sim, scope, drawn, rng)
    nominal, readings, _ = point_pairs(sim, scope, drawn, s00, phi_est[-1], aimed=True)
    origin, cubic = plate_cubic(readings, nominal)
    far = drawn.grid[0] - 1  # align_plate's far circle: the first row's last
    baseline = far * drawn.geometry.plate.pitch_mm
    return sim, Calibration(readings, nominal, origin, cubic, phi_true[-1], baseline, far)


def task_errors(sim: VisionStageSim, cal: Calibration, targets: np.ndarray) -> np.ndarray:
    """The compensated errors (G, 2) um at targets (G, 2) mm: where the table truly goes for
    each compensated command, relative to where it is at ``cal.origin_mm``, less the target's
    reading relative to the same origin (the command's own draws do not enter: the truth is the
    geometric one, approached as the calibration's readings were)."""
    cmd = compensated_command(targets, cal.error_um)
    field = true_error_field(sim, np.vstack([cal.origin_mm, cmd]), cal.phi_residual_rad)[1:]
    return field + (cmd - targets) * 1000


def trial(config: VisionStageConfig, targets: np.ndarray, seed: int) -> np.ndarray:
    """One trial's compensated errors (2 G,) um, x and y at each target in turn."""
    sim, cal = calibrated(config, seed)
    try:
        return task_errors(sim, cal, targets).ravel()
    finally:
        sim.close()


def task_jacobian(cal: Calibration, targets: np.ndarray) -> np.ndarray:
    """d(compensated error at each target, x and y) / d(the cubics' coefficients, x's then
    y's), (2 G, 20) um per coefficient unit (um / mm^k): minus each monomial at the target's
    compensated command, less the origin. A coefficient's move d moves the model by d m(s), the
    command s by minus that (over 1 + the model's slope) and where the table goes by that times
    1 + the true field's slope: the two slopes differ by the cubic's misfit's, 5e-5 (the scales'
    periodic errors), the Jacobian's whole error. (At the target instead of the command the
    monomials are off by the error the command corrects, 60 um: 6e-3 of a cubic term near the
    origin.)"""
    rel = compensated_command(targets, cal.error_um) - cal.origin_mm
    scale = MONOMIAL_SCALE_MM ** np.array([i + j for i, j in monomial_powers(DEGREE)])
    a = design(rel[:, 0], rel[:, 1], DEGREE) * scale  # (G, 10) mm^k
    J = np.zeros((2 * len(targets), 2 * N_COEF))
    J[0::2, :N_COEF], J[1::2, N_COEF:] = -a, -a
    return J


def gum(config: VisionStageConfig, targets: np.ndarray, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """The task's Jacobian (2 G, 20) um per coefficient unit and the two cubics' coefficient
    covariance (20, 20) (:func:`coefficient_cov`), of the reference machine drawn by ``seed``."""
    sim, cal = calibrated(config, seed)
    sim.close()
    return task_jacobian(cal, targets), coefficient_cov(cal)


def coefficient_cov(cal: Calibration) -> np.ndarray:
    """The covariance (20, 20) of both cubics' coefficients (x's a0..a9, then y's), in
    (um / mm^k)^2, from the points' scatter sigma the scenario's fit reports (``fit_plate``'s
    ``sigma_um``, its ``point_scatter_um``).

    Each circle k is seen with one error n_k (2,) um of 1-sigma sigma each way, most of it the
    circle's own (the plate's manufacturing error, 0.5 um, beside the drive's 0.12 um and the
    detector's 0.01 um): the alignment's looks at circles (0, 0) and (nx - 1, 0) see the same
    n_0 and n_f as the grid's. The points' errors less the truth's (``true_error_field``) are
    then linear in the n_k: each point's own, minus the datum's n_0 (every error is relative to
    circle (0, 0)'s reading), plus the measured angle's error dphi = (n_f,y - n_0,y) / baseline
    turning the nominal grid by (-v, u) dphi. The least squares carries them to the
    coefficients: c = A^+ d, whose covariance is sigma^2 L L^T.

    The scenario's reported ``cubic_std`` treats the two shared errors apart: it adds the angle's
    in quadrature to the cross slopes (but the same n_f, n_0 are in the fit's points, and most
    of it cancels at the far targets), and the datum's to a0 alone (most of a0's at 0.5 um).
    """
    plate = fit_plate(cal.readings_mm, cal.nominal_mm, cal.baseline_mm)
    rel = cal.readings_mm - cal.origin_mm
    n, far = len(rel), cal.far_index
    A = design(rel[:, 0], rel[:, 1], DEGREE)  # monomials of reading / 100 mm
    scale = MONOMIAL_SCALE_MM ** np.array([i + j for i, j in monomial_powers(DEGREE)])
    P = np.linalg.pinv(A) / scale[:, None]  # (10, n): a point's error to the coefficients
    # d[k, axis] per unit of n[j, b]: D (n, 2, n, 2)
    D = np.zeros((n, 2, n, 2))
    for a in range(2):
        D[:, a, :, a] -= np.eye(n)  # the point's own
        D[:, a, 0, a] += 1.0  # the datum's
    turn = np.stack([-rel[:, 1], rel[:, 0]], axis=1) / cal.baseline_mm  # (n, 2) per rad * mm
    D[:, :, far, 1] += turn
    D[:, :, 0, 1] -= turn
    L = np.concatenate([np.tensordot(P, D[:, a], axes=(1, 0)) for a in range(2)])  # (20, n, 2)
    L = L.reshape(2 * N_COEF, 2 * n)
    return plate.sigma_um**2 * (L @ L.T)
