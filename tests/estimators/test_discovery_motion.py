"""Drivers derived from the logged columns (:mod:`calibench.estimators.discovery.motion`),
against their definitions worked by hand and a first-order lag against its exact solution."""

import numpy as np

from calibench.estimators.discovery.motion import lagged, last_direction, since_reversal

PATH = np.array([0, 0, 1, 2, 3, 2, 1, 1, 2, 5.0])


def test_direction_of_last_motion_and_travel_since_the_last_reversal():
    """Worked by hand: it turns back at 3 (row 5) and again at 1 (row 8); a dwell keeps the
    direction; a new series (a pass) forgets the one before."""
    np.testing.assert_array_equal(last_direction(PATH), [0, 0, 1, 1, 1, -1, -1, -1, 1, 1])
    np.testing.assert_array_equal(since_reversal(PATH), [0, 0, 1, 2, 3, 1, 2, 2, 1, 4])
    passes = np.repeat([0, 1], 5)
    np.testing.assert_array_equal(last_direction(PATH, passes), [0, 0, 1, 1, 1, 0, -1, -1, 1, 1])


def test_a_lag_follows_a_ramp_as_the_closed_form_says_and_any_sampling_agrees():
    """Air warming 1 K per hour from rest: T_lag(t) = T_air(t) - r tau (1 - exp(-t / tau)), to
    1e-9 K; irregular sampling of a sine agrees with a 10 ms one to the sine's curvature between
    samples (the air taken linear there: 1e-4 K); a recording of 3 days at a 60 s lag keeps its
    numbers finite."""
    t = np.linspace(0.0, 3600.0, 37)
    T = 20.0 + t / 3600.0
    tau = 600.0
    want = T - tau / 3600.0 * (1 - np.exp(-t / tau))
    np.testing.assert_allclose(lagged(T, t, tau), want, atol=1e-9)
    rng = np.random.default_rng(0)
    ti = np.sort(np.r_[0.0, rng.uniform(0, 3600, 400), 3600.0])
    fine = np.linspace(0.0, 3600.0, 360_001)
    a = lagged(20 + np.sin(ti / 500), ti, 300.0)[-1]
    b = lagged(20 + np.sin(fine / 500), fine, 300.0)[-1]
    assert abs(a - b) < 1e-4
    long = np.linspace(0.0, 3 * 86400.0, 5000)
    assert np.all(np.isfinite(lagged(20 + np.sin(long / 3e4), long, 60.0)))
