"""Discovery's pieces on synthetic data from a known truth."""

import warnings

import numpy as np
import pytest

from calibench.estimators.arm.kinematics import Chain, jacobian, point, theta_index
from calibench.estimators.discovery.arm import EncoderEccentricity, TransmissionSearch
from calibench.estimators.discovery.arm_compliance import JointCompliance
from calibench.estimators.discovery.fit import Signal, fit_terms
from calibench.estimators.discovery.harmonics import (
    best_harmonic,
    best_period,
    grid_rel,
    harmonic_grid,
    refine_period,
)
from calibench.estimators.discovery.noise import repeatability
from calibench.estimators.discovery.select import select
from calibench.estimators.discovery.stage import Backlash


def test_periodogram_and_refinement_find_the_period():
    """A 4 um sinusoid of period 47.3 mm on a tilted baseline, 1 um noise, 800 stations over
    400 mm: the period within 4 of its reported std, the std below 0.2 mm."""
    rng = np.random.default_rng(40)
    u = rng.uniform(0, 400, 800)
    base = np.c_[np.ones_like(u), u / 400]
    r = (
        0.01
        + 0.02 * u / 400
        + 0.004 * np.sin(2 * np.pi * u / 47.3 + 1.0)
        + rng.normal(0, 0.001, 800)
    )
    f = np.arange(1 / 200, 1 / 10, 1 / 2000)
    P0, frac = best_period(u, r, base, 1 / f)
    P, P_std = refine_period(u, r, base, P0, rel=grid_rel(1 / f, P0))
    assert frac > 0.7
    assert abs(P - 47.3) < 4 * P_std and P_std < 0.2


def test_repeatability_from_passes():
    """Four passes over 200 stations, 1.5 um noise: sigma within 8 % (600 dof: 3 sigma of the
    estimate is 8.7 %... of the variance; 4.3 % of sigma), whatever the stations' own errors."""
    rng = np.random.default_rng(41)
    station = np.tile(np.arange(200), 4)
    r = rng.normal(0, 0.05, 200)[station] + rng.normal(0, 0.0015, 800)
    nz = repeatability(r, station, np.arange(800))
    assert abs(nz.sigma_mm / 0.0015 - 1) < 0.08 and abs(nz.lag1) < 0.15


def test_repeatability_within_blocks_does_not_absorb_a_drift():
    """72 stations read once per turn over 8 turns, sigma 2 um, and an offset drifting 0-15 um
    from turn to turn: taken across turns the scatter contains the drift; within turns (the
    turn's own offset out, 7 more degrees of freedom spent) it is sigma, within 4 standard
    errors (sigma / sqrt(2 dof))."""
    rng = np.random.default_rng(4)
    sigma, turns, stations = 0.002, 8, 72
    station = np.tile(np.arange(stations), turns)
    turn = np.repeat(np.arange(turns), stations)
    drift = 0.015 * (1 - np.exp(-turn / 3.0))
    r = np.sin(station / 7.0) * 0.01 + drift + rng.normal(0, sigma, len(station))
    across = repeatability(r, station, np.arange(len(r)))
    within = repeatability(r, station, np.arange(len(r)), turn)
    assert within.dof == across.dof - (turns - 1)
    assert abs(within.sigma_mm - sigma) < 4 * sigma / np.sqrt(2 * within.dof)
    assert across.sigma_mm > 1.5 * sigma  # the drift counted as noise
    # without a drift the two agree: a block's offset costs only its degrees of freedom
    calm = r - drift
    order = np.arange(len(r))
    a, w = repeatability(calm, station, order), repeatability(calm, station, order, turn)
    assert abs(w.sigma_mm / a.sigma_mm - 1) < 4 / np.sqrt(2 * w.dof)


def test_selection_takes_backlash_and_leaves_noise_alone():
    rng = np.random.default_rng(42)
    n = 1200
    run = np.repeat(np.arange(4), n // 4)
    x = np.tile(np.r_[np.linspace(0, 300, 150), np.linspace(300, 0, 150)], 4)
    d = np.tile(np.r_[np.ones(150), -np.ones(150)], 4)
    drivers = {"x": x, "dir_x": d, "run": run}
    base = np.c_[np.ones(n), x / 300]
    sig = Signal(
        "x", "x", 0.004 * d + 0.001 * x / 300 + rng.normal(0, 0.001, n), base, np.arange(n), x
    )
    noise = {"x": repeatability(sig.r, np.round(x * 10).astype(int) * 2 + (d > 0), np.arange(n))}
    found, terms = select([sig], [Backlash(axis="x")], drivers, run, noise)
    assert [s.term.name for s in found.steps] == ["backlash"]
    fixed, coef, cov, _ = fit_terms(sig, terms["x"], drivers, {}, noise["x"].sigma_mm)
    assert abs(coef[2] - 0.008) < 5 * np.sqrt(cov[2, 2])
    pure = Signal("x", "x", rng.normal(0, 0.001, n), base, np.arange(n), x)
    found, _ = select([pure], [Backlash(axis="x")], drivers, run, noise)
    assert found.steps == []


def _drivers(chain, q):
    J = jacobian(chain, q)
    return {"q": q, "J": J, "Jq": J[:, :, [theta_index(j) for j in range(1, chain.n_joints + 1)]]}


def _chain():
    return Chain(
        "dh",
        np.array([0, 300, 20, 0, 0, 0.0]),
        np.array([150, 0, 0, 280, 0, 120.0]),
        np.array([np.pi / 2, 0, np.pi / 2, -np.pi / 2, np.pi / 2, 0]),
        np.zeros(6),
        tool_mm=np.array([0.0, 0.0, 60.0]),
    )


def test_eccentricity_columns_match_the_chain():
    """Columns times (A cos ph, A sin ph) = where the probe goes when the reading is off by
    A sin(q + ph): against the chain evaluated at the true angle, to first order in A."""
    rng = np.random.default_rng(43)
    chain = _chain()
    q_read = rng.uniform(-np.pi, np.pi, (30, 6))
    A, ph, j = 4e-6, 0.7, 3
    q_true = q_read.copy()
    q_true[:, j - 1] -= A * np.sin(q_read[:, j - 1] + ph)
    moved = point(chain, q_true) - point(chain, q_read)
    cols = EncoderEccentricity(joint=j).columns(_drivers(chain, q_read))
    # second order: A^2 L ~ 1e-8 mm, against first-order motions of ~1e-3 mm
    np.testing.assert_allclose(cols @ [A * np.cos(ph), A * np.sin(ph)], moved.ravel(), atol=2e-8)


def test_transmission_harmonic_is_found_between_whole_numbers():
    """A joint's angle error at 17.5 cycles per turn (a gear's), found by the harmonic search on
    data made by MuJoCo's twin of the arm (its Table 1 errors too) at the true angles, with
    noise; the search's columns come from the estimator's nominal chain."""
    from calibench.scenarios.arm_cmm.arms import chain_of
    from calibench.sim.arm_cmm import ArmSim, ArmTruth

    rng = np.random.default_rng(44)
    sim = ArmSim("arm-cmm", ArmTruth())
    chain = chain_of(sim.arm)
    q_read = rng.uniform(-np.pi, np.pi, (400, 6))
    q_true = q_read.copy()
    q_true[:, 1] -= 80e-6 * np.sin(17.5 * q_read[:, 1] + 0.3)
    r = (sim.probe_mm(q_true) - sim.probe_mm(q_read) + rng.normal(0, 0.002, (400, 3))).ravel()
    d = _drivers(chain, q_read)
    t = TransmissionSearch(joint=2, harmonics=harmonic_grid(q_read[:, 1])).fix(
        r, np.zeros((1200, 0)), np.ones(1200, bool), d
    )
    assert t.harmonic == pytest.approx(17.5, abs=0.01)
    coef = np.linalg.lstsq(t.columns(d), r, rcond=None)[0]
    assert np.hypot(*coef) == pytest.approx(80e-6, rel=0.05)


def test_harmonic_search_beside_other_columns_is_the_least_squares_optimum():
    """The search sums per posture and projects the other columns off by their Gram matrix: its
    harmonic must be where a plain least-squares fit (the other columns, a sine and a cosine,
    some coordinates left out) explains most, found here by brute force on a fine grid."""
    rng = np.random.default_rng(46)
    chain = _chain()
    q = rng.uniform(-np.pi, np.pi, (300, 6))
    J = jacobian(chain, q)
    Jt = J[:, :, theta_index(3)]
    base = J[:, :, :12].reshape(
        -1, 12
    )  # joints 1-2's parameters: partly like the harmonic's columns
    r = (
        (Jt * (60e-6 * np.sin(13.3 * q[:, 2:3] - 1.0))).ravel()
        + base @ rng.normal(0, 1e-3, 12)
        + rng.normal(0, 0.002, 900)
    )
    rows = rng.random(900) > 0.1
    h, _ = best_harmonic(q[:, 2], Jt, r, base, harmonic_grid(q[:, 2]), rows)

    def explained(hh):
        cols = np.c_[
            base, (Jt * np.sin(hh * q[:, 2:3])).ravel(), (Jt * np.cos(hh * q[:, 2:3])).ravel()
        ][rows]
        return -np.sum((r[rows] - cols @ np.linalg.lstsq(cols, r[rows], rcond=None)[0]) ** 2)

    fine = np.arange(12.8, 13.8, 1e-4)
    best = fine[np.argmax([explained(x) for x in fine])]
    assert h == pytest.approx(best, abs=2e-4) and h == pytest.approx(13.3, abs=0.02)


def test_compliance_column_is_the_sag_of_the_gravity_torque():
    """c tau_j through the joint's column: the chain at q + c tau against the chain at q."""
    rng = np.random.default_rng(45)
    chain = _chain()
    q = rng.uniform(-np.pi, np.pi, (30, 6))
    tau = rng.uniform(-50, 50, (30, 6))
    c = 0.2  # urad / N m: sags up to 1e-5 rad, second order 3e-8 mm
    moved = point(chain, q + np.where(np.arange(6) == 1, c * 1e-6 * tau, 0.0)) - point(chain, q)
    cols = JointCompliance(joint=2).columns({**_drivers(chain, q), "tau": tau})
    np.testing.assert_allclose(cols[:, 0] * c, moved.ravel(), atol=5e-8)


@pytest.mark.parametrize("c_urad_per_nm", (0.3, -0.3))
def test_a_compliance_below_zero_is_never_accepted_whatever_it_cuts(c_urad_per_nm):
    """Joint 2 turned by c tau_2 (the chain moved to q + c tau, 300 postures, 2 um of noise): a
    compliance of 0.3 urad / N m (up to 15 urad) is found at its size within 4 std; the same
    sag against gravity (c < 0: a joint that pushes back harder the more it is loaded) cuts the
    held-out RMS as much, yet is refused with its value, outside its physical range."""
    from calibench.estimators.discovery.noise import Noise

    rng = np.random.default_rng(47)
    chain = _chain()
    n = 300
    q = rng.uniform(-np.pi, np.pi, (n, 6))
    tau = rng.uniform(-50, 50, (n, 6))
    sag = np.where(np.arange(6) == 1, c_urad_per_nm * 1e-6 * tau, 0.0)
    r = (point(chain, q + sag) - point(chain, q)).ravel() + rng.normal(0, 0.002, 3 * n)
    sig = Signal("xyz", "xyz", r, np.ones((3 * n, 1)), np.repeat(np.arange(n), 3))
    drivers = {**_drivers(chain, q), "tau": tau}
    fold = np.repeat(np.arange(n) % 5, 3)
    noise = {"xyz": Noise(0.002, 0.0, 3 * n)}
    found, terms = select([sig], [JointCompliance(joint=2)], drivers, fold, noise)
    if c_urad_per_nm > 0:
        assert [s.term.name for s in found.steps] == ["joint_compliance"], found.rejected
        _, coef, cov, _ = fit_terms(sig, terms["xyz"], drivers, {}, 0.002)
        assert abs(coef[1] - c_urad_per_nm) < 4 * np.sqrt(cov[1, 1]), (coef, cov)
    else:
        assert found.steps == [], found.steps
        assert "below zero" in found.rejected["joint_compliance:joint2"], found.rejected


def test_stewart_pitch_effect_reports_the_injected_amplitude_and_phase():
    """A 4 um pitch error of 5 mm lead on leg 4 under 1 um of reading noise, 300 poses: the fit
    of its sine and cosine reports the amplitude and phase within 4 of their std, and that std
    is the noise's, sigma sqrt(2 / n) = 0.08 um (the estimate's own std from 300 rows: within
    20 %)."""
    from calibench.estimators.discovery.stewart import LegPitch, on_leg

    rng = np.random.default_rng(21)
    n, amp, phase, sigma = 300, 4e-3, 0.7, 1e-3
    L = rng.uniform(400.0, 600.0, (n, 6))
    effect = LegPitch(leg=4, period_mm=5.0)
    r = on_leg(amp * np.sin(2 * np.pi * L[:, 3] / 5.0 + phase), 4).ravel()
    r += rng.normal(0, sigma, 6 * n)
    X = effect.columns({"L": L})[6 * np.arange(n) + 3]  # leg 4's rows
    coef, res, *_ = np.linalg.lstsq(X, r[6 * np.arange(n) + 3], rcond=None)
    cov = res[0] / (n - 2) * np.linalg.inv(X.T @ X)
    params, std, _ = effect.describe(coef, cov)
    assert abs(params["amplitude_mm"] - amp) < 4 * std["amplitude_mm"], params
    assert abs(params["phase_rad"] - phase) < 4 * std["amplitude_mm"] / amp, params
    assert std["amplitude_mm"] == pytest.approx(sigma * np.sqrt(2 / n), rel=0.2)


def test_repeats_that_agree_exactly_leave_no_scatter_to_judge_by():
    """A read-out of 10 um steps (a coarse scale) whose noise is well inside a step repeats each
    station's reading exactly: the scatter is the means' rounding, not noise, so there is no
    sigma (and no warning from a correlation of zeros); half a quantum of true scatter is
    measured as such (150 dof: sigma within 4 of its relative standard error 1/sqrt(300), 0.23)."""
    rng = np.random.default_rng(7)
    station = np.tile(np.arange(50), 4)
    true = rng.normal(0, 0.05, 50)
    r = np.round(true / 0.01)[station] * 0.01 + 0.1  # every repeat the same number
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        nz = repeatability(r, station, np.arange(200))
    assert nz.sigma_mm is None and nz.dof == 150 and nz.lag1 == 0.0
    noisy = r + rng.normal(0, 0.005, 200)
    assert abs(repeatability(noisy, station, np.arange(200)).sigma_mm / 0.005 - 1) < 0.25
