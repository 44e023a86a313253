"""Compensation models: the cubic (Eq. 5-9), the CV-selected model, the line ruler (Eq. 3-4)."""

import numpy as np
import pytest

from calibench.estimators.stage.compensation import (
    LineRuler,
    compensated_command,
    cv_rms,
    cv_rms_periodic,
    fit_polynomial,
    monomial_powers,
    select_model,
)

TRUE = np.array([0.3, 0.19, 0.08, 1.5e-4, -2e-5, -1.1e-4, -3.9e-7, 2e-8, 6e-8, -8e-7])  # um / mm^k


def _grid():
    v, u = np.mgrid[0:13, 0:20] * 15.0
    return u.ravel(), v.ravel()


def _cubic(u, v):
    return np.stack([u**i * v**j for i, j in monomial_powers(3)], axis=-1) @ TRUE


def test_cubic_has_the_papers_ten_terms_in_order():
    assert monomial_powers(3) == [
        (0, 0),
        (1, 0),
        (0, 1),
        (2, 0),
        (1, 1),
        (0, 2),
        (3, 0),
        (2, 1),
        (1, 2),
        (0, 3),
    ]


def test_cubic_recovers_coefficients_and_its_std_is_honest():
    u, v = _grid()
    rng = np.random.default_rng(13)
    sigma = 0.5
    est = np.array(
        [fit_polynomial(u, v, _cubic(u, v) + rng.normal(0, sigma, u.size)).coef for _ in range(300)]
    )
    std = fit_polynomial(u, v, _cubic(u, v)).coef_std(u, v, sigma)
    z = (est - TRUE) / std
    assert np.all(np.abs(z.mean(axis=0)) < 4 / np.sqrt(300))
    np.testing.assert_allclose(z.std(axis=0), 1, atol=0.15)


def test_cross_validation_finds_a_periodic_scale_error():
    u, v = _grid()
    rng = np.random.default_rng(14)
    err = _cubic(u, v) + 0.8 * np.sin(2 * np.pi * u / 95.0 + 0.4) + rng.normal(0, 0.3, u.size)
    model, scores = select_model(u, v, err, along=0)
    assert model.period_mm == pytest.approx(95.0, rel=0.03)
    assert scores[f"degree 3 + period {model.period_mm:.1f} mm"] < scores["degree 3"] / 1.5
    # and stays with a polynomial when there is nothing periodic
    model, _ = select_model(u, v, _cubic(u, v) + rng.normal(0, 0.3, u.size), along=0)
    assert model.period_mm is None


def test_periodic_cross_validation_at_once_equals_one_fit_per_period():
    """The factored search (the cubic once per fold, each period's two columns on what it leaves)
    gives the joint least squares' cross-validated error of every period, to rounding."""
    u, v = _grid()
    rng = np.random.default_rng(3)
    err = _cubic(u, v) + 0.8 * np.sin(2 * np.pi * v / 61.0) + rng.normal(0, 0.3, u.size)
    periods = np.array([20.0, 47.5, 61.0, 140.0])
    rms, se = cv_rms_periodic(u, v, err, periods, along=1)
    for p, r, s in zip(periods, rms, se):
        r1, s1 = cv_rms(u, v, err, degree=3, period_mm=p, along=1)
        assert r == pytest.approx(r1, rel=1e-9) and s == pytest.approx(s1, rel=1e-6)


def test_cross_validation_is_a_fit_per_fold_to_the_last_bit():
    """cv_rms builds the design once and skips the std: each fold's error equals the one of
    fit_polynomial on the fold's training points, predicted by the fitted model, bit for bit."""
    u, v = _grid()
    rng = np.random.default_rng(5)
    err = _cubic(u, v) + 0.6 * np.sin(2 * np.pi * u / 80.0) + rng.normal(0, 0.3, u.size)
    folds = 10
    fold = np.empty(u.size, int)
    fold[np.random.default_rng(0).permutation(u.size)] = np.arange(u.size) % folds
    for model in (
        dict(degree=1),
        dict(degree=3),
        dict(degree=6),
        dict(degree=3, period_mm=80.0, along=0),
    ):
        mse = []
        for k in range(folds):
            tr, te = fold != k, fold == k
            m = fit_polynomial(u[tr], v[tr], err[tr], **model)
            mse.append(float(np.mean((err[te] - m(u[te], v[te])) ** 2)))
        mse = np.array(mse)
        assert cv_rms(u, v, err, folds, **model) == (
            float(np.sqrt(mse.mean())),
            float(mse.std(ddof=1) / np.sqrt(folds)),
        )
    with pytest.raises(ValueError, match="cannot fit"):
        cv_rms(u[:40], v[:40], err[:40], degree=8)


def test_line_ruler_equations_3_and_4():
    pitch = 10.0
    true_err_um = lambda r: 0.2 * r + 1.5 * np.sin(r / 30.0)  # noqa: E731
    grads = np.arange(30) * pitch
    # reading at graduation k: true position k*pitch = reading + error(reading) -> solve
    readings = grads.copy()
    for _ in range(30):
        readings = grads - true_err_um(readings) / 1000
    ruler = LineRuler.from_graduations(readings + 4.0, pitch)  # an arbitrary reading origin
    e0 = true_err_um(readings[0])
    np.testing.assert_allclose(ruler.err_um, true_err_um(readings) - e0, atol=1e-9)
    mid = (readings[:-1] + readings[1:]) / 2 + 4.0
    np.testing.assert_allclose(ruler(mid), (ruler.err_um[:-1] + ruler.err_um[1:]) / 2, atol=1e-12)
    with pytest.raises(ValueError):
        LineRuler.from_graduations(np.array([0.0, 5.0, 4.0]), pitch)


def test_compensated_command_inverts_the_model():
    model = lambda s: np.stack([200e-3 * s[:, 0], -140e-3 * s[:, 1]], axis=1)  # noqa: E731  um
    target = np.array([[100.0, 50.0], [290.0, 180.0]])
    s = compensated_command(target, model)
    np.testing.assert_allclose(s + model(s) / 1000, target, atol=1e-12)
