"""The probe scanner's uncertainty task (issue 64): the traced rim's compensated radius around the
turn (scenarios/probe_scanner/uncertainty.py). Its Jacobian is the task's differences, a trial
is its seed's, compensation takes the rail's millimetres of error to a fraction of a micrometre,
and the Monte Carlo's spread is what the calibration's stated covariance propagates to."""

from functools import partial

import numpy as np
from scipy.stats import chi2

from calibench.scenarios.probe_scanner import uncertainty as task
from calibench.scenarios.probe_scanner.scenario import ProbeScannerConfig

CONFIG = ProbeScannerConfig()
PHI, POINTS = task.grid(CONFIG)
TRIALS = 40  # the spread's machines: 40 x 0.12 s of CPU


def _smooth_radius(phi):
    """A smooth rim (mm at rad) whose slope is known exactly: the Jacobian's algebra is checked
    against it, apart from the rim's own slope."""
    return 24.0 + 2.5 * np.cos(2 * phi - 0.3) + 0.7 * np.sin(3 * phi + 1.1)


def _smooth_slope(phi):
    return -5.0 * np.sin(2 * phi - 0.3) + 2.1 * np.cos(3 * phi + 1.1)


def test_the_tasks_jacobian_is_its_radius_errors_differences():
    """At the reference machine's calibration and rim readings, each of (d, dL, alpha0) moved by
    1e-5 of a millimetre or radian either way: the radius error moves as the Jacobian's column
    says. The central difference's error is the third derivative times h^2 / 6 (the radius's
    third derivatives are O(10) mm per unit^3 here: ~1e-9 mm per unit) and its rounding 1e-16 x
    25 mm / 1e-5 (~3e-10): 1e-7 mm per unit bounds both. The plate's centre moves nothing."""
    _, _, cal, theta, rho = task.traced(CONFIG, PHI, 3)
    p = task.parameters(cal)
    J = task.task_jacobian(theta, rho, p, _smooth_slope)
    h = 1e-5
    for k in range(5):
        e = np.zeros(5)
        e[k] = h
        plus = task.radius_error_mm(theta, rho, p + e, _smooth_radius)
        minus = task.radius_error_mm(theta, rho, p - e, _smooth_radius)
        np.testing.assert_allclose(J[:, k], (plus - minus) / (2 * h), rtol=0, atol=1e-7)
    assert np.all(J[:, 3:] == 0) and np.abs(J[:, 2]).max() > 1.0  # alpha0 matters off-circle


def test_the_rims_slope_and_radius_are_the_walls():
    """The Jacobian takes the exact rim's slope; the trial judges against MuJoCo's walls, the
    curve's chords, whose slopes are the curve's within 0.1 mm/rad. The two radii agree to
    the chords' sagitta (the scene keeps it under 0.05 um: 0.06 um allows the dense outline's
    own linear pieces, under 1e-3 um), and the slope's central difference is settled: halving
    its step moves it by under 1e-4 of its largest value (the step's error goes as its square;
    the outline's pieces 1.6e-4 rad wide are still averaged over at the half step)."""
    sim, drawn, _, _, _ = task.traced(CONFIG, PHI, 3)
    lens = drawn.geometry.lens
    walls = sim.radius_mm("lens", PHI + 0.01)
    np.testing.assert_allclose(walls, task.rim_radius_mm(lens, PHI + 0.01), rtol=0, atol=6e-5)
    assert np.all(walls <= task.rim_radius_mm(lens, PHI + 0.01) + 1e-9)  # chords lie inside
    slope = task.rim_slope(lens, PHI)
    half = (
        task.rim_radius_mm(lens, PHI + task.SLOPE_STEP_RAD / 2)
        - task.rim_radius_mm(lens, PHI - task.SLOPE_STEP_RAD / 2)
    ) / task.SLOPE_STEP_RAD
    np.testing.assert_allclose(half, slope, rtol=0, atol=1e-4 * np.abs(slope).max())
    # the walls' own slope under each angle (a 1e-6 rad step stays on one 94 um chord): the
    # chords turn by their length over the rim's radius of curvature, so their slopes stand
    # off the curve's by under 0.08 mm/rad (720 angles), 5 nm of u through alpha0's 60 urad
    h = 1e-6
    walls_slope = (sim.radius_mm("lens", PHI + h) - sim.radius_mm("lens", PHI - h)) / (2 * h)
    np.testing.assert_allclose(walls_slope, slope, rtol=0, atol=0.1)


def test_a_trial_is_its_seeds_and_compensation_takes_millimetres_to_submicrometres():
    """The same seed after another gives the very same values; another seed other values. The
    design values (d 7.5, dL 3.4 mm, alpha0 0.30 rad) against a machine drawn from the prior
    (d 6-10, dL 2-4 mm, alpha0 0.25-0.45 rad) miss the rim by hundreds of micrometres (a tenth
    of a millimetre of dL is 100 um of radius); the calibration's u is 0.06-0.3 um, so the
    compensated errors stay within 5 u < 2 um: a thousandth of the uncompensated rms holds
    with room either way."""
    first = task.trial(CONFIG, PHI, 11)
    other = task.trial(CONFIG, PHI, 12)
    again = task.trial(CONFIG, PHI, 11)
    assert first.shape == (len(PHI),) and len(task.labels(POINTS)) == len(first)
    np.testing.assert_array_equal(first, again)
    assert not np.allclose(first, other)
    for seed in (11, 12):
        sim, _, cal, theta, rho = task.traced(CONFIG, PHI, seed)
        n = CONFIG.nominal
        before = 1000 * task.radius_error_mm(
            theta, rho, np.r_[n.d_mm, n.dL_mm, n.alpha0_rad], partial(sim.radius_mm, "lens")
        )
        after = task.trial(CONFIG, PHI, seed)
        assert np.abs(after).max() < 2.0, after
        assert np.sqrt(np.mean(after**2)) < 1e-3 * np.sqrt(np.mean(before**2)), (after, before)


def test_the_monte_carlos_spread_is_the_gum_frameworks():
    """Over 40 machines from the prior, each calibrated on its own turn of the plate:

    1. The spread of each grid radius against the rms over those machines of each one's GUM u
       (its calibration's stated covariance through its Jacobian): the sample standard
       deviation of 40 normal values over sigma lies within sqrt(chi2(39) / 39)'s 99.9 %
       two-sided bounds, [0.65, 1.38] (the 24 radii share three parameters: a handful of
       independent checks, not 24). 200 machines gave 0.93-0.98: the estimator's covariance
       is right (its samples are independent enough: the probe's 2 um noise dithers the 5 um
       quantum) and the task is linear over micrometres.
    2. The study's GUM u is one reference machine's (the seed's): machines differ (the rail's
       offset d of 6-10 mm sets how the plate's minima pin d, its std 1.0-1.6 um), so its u is
       0.75-1.22 of the machines' rms (200 machines): within [0.7, 1.3].
    3. The mean error is zero within 4 of its standard errors (the GUM interval is about
       zero); 200 machines gave at most 2.5 (-0.02 um at 60-105 degrees, 0.07 u).
    So the study's Monte Carlo and GUM u agree within 1.38 / 0.7 ~ 2 either way at 40 trials,
    and within the machines' 0.75-1.22 as the trials grow."""
    values, u = [], []
    for seed in range(TRIALS):
        sim, drawn, cal, theta, rho = task.traced(CONFIG, PHI, 5000 + seed)
        p = task.parameters(cal)
        values.append(1000 * task.radius_error_mm(theta, rho, p, partial(sim.radius_mm, "lens")))
        J = 1000 * task.task_jacobian(theta, rho, p, partial(task.rim_slope, drawn.geometry.lens))
        u.append(np.sqrt(np.einsum("ij,jk,ik->i", J, cal.cov, J)))
    values, u = np.array(values), np.array(u)
    spread = values.std(axis=0, ddof=1)
    machines = np.sqrt(np.mean(u**2, axis=0))
    lo, hi = np.sqrt(chi2.ppf([0.0005, 0.9995], TRIALS - 1) / (TRIALS - 1))
    ratio = spread / machines
    assert np.all((ratio > lo) & (ratio < hi)), ratio
    J, C = task.gum(CONFIG, PHI, 7)
    reference = np.sqrt(np.einsum("ij,jk,ik->i", J, C, J))
    assert np.all((reference / machines > 0.7) & (reference / machines < 1.3))
    mean = values.mean(axis=0)
    assert np.all(np.abs(mean) < 4 * spread / np.sqrt(TRIALS)), mean / spread


def test_the_grid_and_labels_name_each_place():
    """24 places every 15 degrees on the rim (its radius 17.5-26 mm about the table's axis), each
    labelled with its angle and radius, one quantity a place."""
    labels = task.labels(POINTS)
    assert [lab["at"]["angle_deg"] for lab in labels] == [15.0 * k for k in range(24)]
    assert all(17 < lab["at"]["r_mm"] < 27 and lab["quantity"] == "radius" for lab in labels)
    assert POINTS.shape == (24, 3) and task.UNIT == "um" and task.TASK


def test_the_as_built_twin_is_its_mjcfs_model():
    """A trial's twin is the design's compiled model with the as-built written in
    (scenes.probe_scanner.as_built_model, 6 ms against 50 ms to compile): every array of it is
    the very model its MJCF compiles to, bit for bit, for machines across the prior."""
    import mujoco

    from calibench.scenes.probe_scanner import as_built_model, build_mjcf

    g = CONFIG.geometry
    for args in [(8.0, 3.0, 0.35, (0.12, -0.08)), (6.3, 2.2, 0.44, (-0.2, 0.1)), (9.9, 3.9, 0.26)]:
        compiled = mujoco.MjModel.from_xml_string(build_mjcf(g, *args))
        written = as_built_model(g, *args)
        for name in dir(compiled):
            a = getattr(compiled, name) if not name.startswith("_") else None
            if isinstance(a, np.ndarray):
                np.testing.assert_array_equal(getattr(written, name), a, err_msg=name)
