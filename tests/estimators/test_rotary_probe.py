"""The frame tracer's calibration on synthetic turns (no MuJoCo): readings found by bisection along
the rail on the opening's distance function, independent of the estimator's closed-form model."""

import numpy as np
import pytest

from calibench.estimators.probe_scanner.calibration import (
    MinimumFit,
    ScannerCalibration,
    calibrate_lsq,
    calibrate_paper,
    contour_points,
    fit_minima,
    paper_sweep_d_mm,
    rounded_square_rho,
    solve_four_minima,
)

A, R = 22.5, 5.0
TRUE = dict(d=8.0, dL=3.0, alpha0=0.35, c=np.array([0.12, -0.08]))
TH = np.arange(1600) * 2 * np.pi / 1600


def _wall_distance(p: np.ndarray, centre) -> np.ndarray:
    """Signed distance from points to the opening's wall, from the rounded square's definition
    (the square of half-side A - R grown by R), negative inside.

    Parameters
    ----------
    p : (n, 2) points in the holder frame, mm.
    centre : (2,) the opening's centre, mm.

    Returns
    -------
    (n,) mm.
    """
    q = np.abs(p - np.asarray(centre, float)) - (A - R)
    return np.linalg.norm(np.maximum(q, 0), axis=1) + np.minimum(q.max(axis=1), 0) - R


def _ray_rho(theta, d, dL, alpha0, centre) -> np.ndarray:
    """Exact readings by bisection along the rail from the stylus's start Q to the wall (the
    opening is convex: one crossing), independent of :func:`rounded_square_rho`.

    Parameters
    ----------
    theta : (n,) table angles, rad.
    d, dL, alpha0 : the rail's geometry (mm, mm, rad), as the module's docstring defines it.
    centre : (2,) the opening's centre, mm.

    Returns
    -------
    (n,) readings, mm (to ~1e-14 mm: 60 halvings of 2 A sqrt 2).
    """
    a = alpha0 + np.asarray(theta, float)
    u = np.stack([np.cos(a), np.sin(a)], axis=1)
    q = d * np.stack([-np.sin(a), np.cos(a)], axis=1) + dL * u
    lo, hi = np.zeros(len(a)), np.full(len(a), 2 * np.sqrt(2) * A)
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        out = _wall_distance(q + mid[:, None] * u, centre) > 0
        lo, hi = np.where(out, lo, mid), np.where(out, mid, hi)
    return 0.5 * (lo + hi)


def _turn(rng, sigma=0.002, quantum=0.005):
    rho = _ray_rho(TH, TRUE["d"], TRUE["dL"], TRUE["alpha0"], TRUE["c"])
    return np.round((rho + rng.normal(0, sigma, rho.size)) / quantum) * quantum


def test_model_reading_is_the_ray_to_the_wall():
    """The estimator's closed-form reading (flat sides and corner circles) against bisection on
    the opening's distance function, off-centre, over a full turn: equal to 1e-9 mm (the
    bisection is exact to ~1e-14 mm)."""
    rho = rounded_square_rho(TH, TRUE["d"], TRUE["dL"], TRUE["alpha0"], TRUE["c"], A, R)
    np.testing.assert_allclose(
        rho, _ray_rho(TH, TRUE["d"], TRUE["dL"], TRUE["alpha0"], TRUE["c"]), atol=1e-9
    )


def test_contour_points_lie_on_the_opening():
    """Exact readings (bisection) turned into contact points with the true rail: each on the
    opening's wall by its distance function, to 1e-9 mm (rounding)."""
    rho = _ray_rho(TH, TRUE["d"], TRUE["dL"], TRUE["alpha0"], TRUE["c"])
    p = contour_points(TH, rho, TRUE["d"], TRUE["dL"], TRUE["alpha0"])
    np.testing.assert_allclose(_wall_distance(p, TRUE["c"]), 0, atol=1e-9)


def test_minima_are_the_sides_feet():
    rho = _ray_rho(TH, TRUE["d"], TRUE["dL"], TRUE["alpha0"], [0, 0])
    fits = fit_minima(TH, rho, 9)
    # rho_min = sqrt(a^2 - d^2) - dL; curvature a^2 / sqrt(a^2 - d^2); alpha0 + theta = psi -
    # asin(d/a)
    for f in fits:
        assert f.rho_mm == pytest.approx(np.sqrt(A**2 - 64) - 3.0, abs=1e-5)
        # the window sits on the samples, not the vertex, and the curve is skewed (d != 0): the
        # quadratic's curvature is off by a few 0.1 % (which is why d from it is hard)
        assert f.curvature_mm == pytest.approx(A**2 / np.sqrt(A**2 - 64), rel=5e-3)
    psi = (np.array([f.theta_rad for f in fits]) + TRUE["alpha0"] + np.arcsin(8 / A)) % (np.pi / 2)
    np.testing.assert_allclose(np.minimum(psi, np.pi / 2 - psi), 0, atol=1e-4)  # same skew


def test_closed_form_is_exact_on_exact_minima():
    d, dL, alpha0, a = 8.0, 3.0, 0.35, A
    phi = -np.arcsin(d / a)
    fits = [
        MinimumFit(
            theta_rad=float((psi + phi - alpha0) % (2 * np.pi)),
            rho_mm=np.sqrt(a * a - d * d) - dL,
            curvature_mm=a * a / np.sqrt(a * a - d * d),
        )
        for psi in np.deg2rad([0, 90, 180, 270])
    ]
    cal = solve_four_minima(fits, a, alpha0_nominal_rad=0.3)
    assert (cal.d_mm, cal.dL_mm, cal.alpha0_rad) == pytest.approx((d, dL, alpha0), abs=1e-9)


def test_paper_method_without_noise_meets_the_requirement_but_not_better():
    """The quadratic cannot centre on the vertex (samples) nor follow the curve's skew (d != 0):
    even noise-free, d is off by a few tenths of a mm; the requirement is 0.5 mm."""
    rho = _ray_rho(TH, TRUE["d"], TRUE["dL"], TRUE["alpha0"], [0, 0])
    errs = [calibrate_paper(TH, rho, m, A, 0.3).d_mm - 8.0 for m in (7, 15, 31, 51)]
    assert max(abs(e) for e in errs) < 0.5
    assert max(abs(e) for e in errs) > 0.02


def test_sweep_of_every_window_at_once_equals_one_fit_per_window():
    """paper_sweep_d_mm (all window sizes padded into one solve) gives each window's own d."""
    rng = np.random.default_rng(5)
    rho = _ray_rho(TH, TRUE["d"], TRUE["dL"], TRUE["alpha0"], [0, 0]) + rng.normal(0, 2e-4, TH.size)
    ms = np.arange(5, 60, 3)
    own = [calibrate_paper(TH, rho, int(m), A, 0.3).d_mm for m in ms]
    np.testing.assert_allclose(paper_sweep_d_mm(TH, rho, ms, A), own, rtol=1e-9, atol=1e-9)


def test_lsq_recovers_the_truth_and_its_std_is_honest():
    z = []
    for seed in range(30):
        rng = np.random.default_rng(seed)
        rho = _turn(rng)
        start = ScannerCalibration(7.5, 3.4, 0.30, np.zeros(2))
        cal = calibrate_lsq(TH, rho, A, R, start)
        est = np.r_[cal.d_mm, cal.dL_mm, cal.alpha0_rad, cal.centre_mm]
        std = np.array([cal.std[k] for k in ("d_mm", "dL_mm", "alpha0_rad", "cx_mm", "cy_mm")])
        z.append((est - np.r_[TRUE["d"], TRUE["dL"], TRUE["alpha0"], TRUE["c"]]) / std)
    z = np.array(z)
    assert np.all(np.abs(z) < 5)
    assert 0.7 < np.sqrt(np.mean(z**2)) < 1.3


def test_alpha0_branch_follows_the_nominal():
    rho = _ray_rho(TH, TRUE["d"], TRUE["dL"], TRUE["alpha0"], [0, 0])
    ref = calibrate_paper(TH, rho, 9, A, 0.35).alpha0_rad
    assert ref == pytest.approx(0.35, abs=0.5 / A)  # the requirement on d, through asin(d / a)
    for nominal in (0.2, 0.6, -0.3):  # within 45 degrees of the truth
        assert calibrate_paper(TH, rho, 9, A, nominal).alpha0_rad == pytest.approx(ref, abs=1e-12)
    with pytest.raises(ValueError):
        fit_minima(TH, rho, 2)
