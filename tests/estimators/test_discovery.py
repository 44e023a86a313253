"""Discovery's pieces on synthetic data from a known truth."""

import numpy as np

from calibench.estimators import discovery as dsc
from calibench.estimators.arm_kinematics import DHChain, jacobian, point_in_link7
from calibench.estimators.effects import Backlash, EncoderEccentricity, best_period


def test_periodogram_and_refinement_find_the_period():
    """A 4 um sinusoid of period 47.3 mm on a tilted baseline, 1 um noise, 800 stations over
    400 mm: the period within 4 of its reported std, the std below 0.2 mm."""
    rng = np.random.default_rng(40)
    u = rng.uniform(0, 400, 800)
    base = np.c_[np.ones_like(u), u / 400]
    r = 0.01 + 0.02 * u / 400 + 0.004 * np.sin(2 * np.pi * u / 47.3 + 1.0) + rng.normal(0, 0.001, 800)
    f = np.arange(1 / 200, 1 / 10, 1 / 2000)
    P0, frac = best_period(u, r, base, 1 / f)
    P, P_std = dsc.refine_period(u, r, base, P0, rel=dsc._grid_rel(1 / f, P0))
    assert frac > 0.7
    assert abs(P - 47.3) < 4 * P_std and P_std < 0.2


def test_repeatability_from_passes():
    """Four passes over 200 stations, 1.5 um noise: sigma within 8 % (600 dof: 3 sigma of the
    estimate is 8.7 %... of the variance; 4.3 % of sigma), whatever the stations' own errors."""
    rng = np.random.default_rng(41)
    station = np.tile(np.arange(200), 4)
    r = rng.normal(0, 0.05, 200)[station] + rng.normal(0, 0.0015, 800)
    nz = dsc.repeatability(r, station, np.arange(800))
    assert abs(nz.sigma_mm / 0.0015 - 1) < 0.08 and abs(nz.lag1) < 0.15


def test_selection_takes_backlash_and_leaves_noise_alone():
    rng = np.random.default_rng(42)
    n = 1200
    run = np.repeat(np.arange(4), n // 4)
    x = np.tile(np.r_[np.linspace(0, 300, 150), np.linspace(300, 0, 150)], 4)
    d = np.tile(np.r_[np.ones(150), -np.ones(150)], 4)
    drivers = {"x": x, "dir_x": d, "run": run}
    base = np.c_[np.ones(n), x / 300]
    sig = dsc.Signal("x", "x", 0.004 * d + 0.001 * x / 300 + rng.normal(0, 0.001, n), base, np.arange(n), x)
    noise = {"x": dsc.repeatability(sig.r, np.round(x * 10).astype(int) * 2 + (d > 0), np.arange(n))}
    found, terms = dsc.select([sig], [Backlash(axis="x")], drivers, run, noise)
    assert [s.term.name for s in found.steps] == ["backlash"]
    fixed, coef, cov, _ = dsc.fit_terms(sig, terms["x"], drivers, {}, noise["x"].sigma_mm)
    assert abs(coef[2] - 0.008) < 5 * np.sqrt(cov[2, 2])
    pure = dsc.Signal("x", "x", rng.normal(0, 0.001, n), base, np.arange(n), x)
    found, _ = dsc.select([pure], [Backlash(axis="x")], drivers, run, noise)
    assert found.steps == []


def test_eccentricity_columns_match_the_chain():
    """Columns times (A cos ph, A sin ph) = where the probe goes when the reading is off by
    A sin(q + ph): against the chain evaluated at the true angle, to first order in A."""
    rng = np.random.default_rng(43)
    chain = DHChain(np.array([0, 300, 20, 0, 0, 0, 0.0]), np.array([150, 0, 0, 280, 0, 120, 60.0]),
                    np.array([np.pi / 2, 0, np.pi / 2, -np.pi / 2, np.pi / 2, 0, 0]))
    q_read = rng.uniform(-np.pi, np.pi, (30, 6))
    A, ph, j = 4e-6, 0.7, 3
    q_true = q_read.copy()
    q_true[:, j - 1] -= A * np.sin(q_read[:, j - 1] + ph)
    moved = point_in_link7(chain, q_true) - point_in_link7(chain, q_read)
    e = EncoderEccentricity(joint=j)
    cols = e.columns({"q": q_read, "J": jacobian(chain, q_read)})
    # second order: A^2 L ~ 1e-8 mm, against first-order motions of ~1e-3 mm
    np.testing.assert_allclose(cols @ [A * np.cos(ph), A * np.sin(ph)], moved.ravel(), atol=2e-8)
