"""Sabotage: small deliberate faults in the library that the suite must catch (issue 15).

A pytest plugin. Loaded with ``-p tests.sabotage`` and given a fault's name in the environment,
it applies that one fault at the start of the session, before any test module is imported::

    CALIBENCH_SABOTAGE=chessboard_bias_0p03px python -m pytest -p tests.sabotage
    tests/estimators/test_chessboard.py

and the run must fail. Each fault wraps the real function (or method) and changes its answer
by a small, precise amount; the names the library imports from one module into another are
replaced too, so the whole library sees the fault, and so does any test that generates its data
with the library's own code (a test whose evidence agrees with itself by construction stays
green under its fault: that is what this check exposes). Without the variable nothing is
patched. ``tests/test_sabotage.py`` runs every fault against its targets.

``FAULTS`` maps a name to the fault: what it does, how it is applied, and the tests that should
catch it (kept short: each list runs in seconds).
"""

from __future__ import annotations

import dataclasses
import functools
import os
from collections.abc import Callable

import numpy as np
import pytest

from tests import sabotage_faults as more
from tests.sabotage_arm import ARM_FAULTS
from tests.sabotage_faults import replace as _replace
from tests.sabotage_faults import wrap as _wrap
from tests.sabotage_uncertainty import UNCERTAINTY_FAULTS

ENV = "CALIBENCH_SABOTAGE"


@dataclasses.dataclass(frozen=True)
class Fault:
    """One deliberate fault: what it does, ``apply(monkeypatch)``, the test node ids or files that
    must catch it, and, for a fault no test catches yet, why (``tests/test_sabotage.py`` then
    expects it to pass unseen: a strict xfail that turns red once a test catches it)."""

    description: str
    apply: Callable[[pytest.MonkeyPatch], None]
    targets: tuple[str, ...]
    uncaught: str = ""


# --- 1. the arm's DH model -----------------------------------------------------------------------
def _arm_nominal(joint: int, column: int, error_rad: float) -> Callable[[pytest.MonkeyPatch], None]:
    """A fault adding ``error_rad`` to one joint's nominal angle in the estimators' chain only
    (``Chain.nominal``: the MuJoCo twin builds its bodies from the arm description, untouched)."""

    def apply(mp):
        from calibench.estimators.arm import kinematics as ak

        real = ak.Chain.nominal

        @functools.wraps(real)
        def nominal(self):
            values = real(self)  # a fresh (N, 5) array
            values[joint - 1, column] += error_rad
            return values

        mp.setattr(ak.Chain, "nominal", nominal)

    return apply


# --- 2. the rotary probe's reading model ----------------------------------------------------------
def _probe_model_1pct(mp):
    """Every reading the model predicts 1 % long."""
    _wrap(
        mp,
        "calibench.estimators.probe_scanner.calibration",
        "rounded_square_rho",
        lambda rho, *a, **k: 1.01 * rho,
    )


# --- 3. the chessboard detector -------------------------------------------------------------------
def _chessboard_bias(mp):
    """+0.03 px in x on every corner of every detected board."""
    _wrap(
        mp,
        "calibench.estimators.camera.chessboard",
        "find_chessboard_corners",
        lambda c, *a, **k: None if c is None else c + np.array([0.03, 0.0]),
    )


# --- 4. the belt stage's map std ------------------------------------------------------------------
def _belt_map_std_1p6x(mp):
    """The 12 map coefficients' reported 1-sigma 1.6 x (the std the report carries)."""

    def inflate(std, *a, **k):
        std = np.array(std, float)
        std[:12] *= 1.6  # ex c0..c5, ey c0..c5; the board's yaw (13th) untouched
        return std

    _wrap(mp, "calibench.estimators.stage.belt_maps", "propagated_std", inflate)


def _error_map_std_1p6x(mp):
    """Every coefficient std of the quadratic map fit 1.6 x."""
    _wrap(
        mp,
        "calibench.estimators.stage.error_map",
        "fit_quadratic",
        lambda fit, *a, **k: dataclasses.replace(fit, std=1.6 * fit.std),
    )


# --- 5. a dropped term ----------------------------------------------------------------------------
def _map_xy_term_dropped(mp):
    """The fitted map evaluated without its x y term (c4): the fit and its report are untouched,
    the compensation that evaluates the map is not."""
    from calibench.estimators.stage import error_map as em

    real = em.QuadraticFit.__call__

    @functools.wraps(real)
    def call(self, x_mm, y_mm):
        coef = self.coef.copy()
        coef[4] = 0.0
        return real(dataclasses.replace(self, coef=coef), x_mm, y_mm)

    mp.setattr(em.QuadraticFit, "__call__", call)


def _gravity_tool_term_dropped(mp):
    """The tool's weight left out of the gravity moments (the load the compliance model turns
    by)."""
    from calibench.estimators.arm import kinematics as ak

    real = ak.gravity_moments

    @functools.wraps(real)
    def moments(chain, *args, **kwargs):
        return real(dataclasses.replace(chain, tool_mass_kg=0.0), *args, **kwargs)

    _replace(mp, "calibench.estimators.arm.kinematics", "gravity_moments", moments)


# --- 6. one parameter's std -----------------------------------------------------------------------
def _stewart_leg_std_1p3x(mp):
    """One of the one-step leg calibration's seven std 1.3 x."""

    def scale(cal, *a, **k):
        std = cal.std.copy()
        std[6] *= 1.3  # the leg's initial length l, of (a, b, c, m, n, q, l)
        return dataclasses.replace(cal, std=std)

    _wrap(mp, "calibench.estimators.stewart.legs", "calibrate_leg", scale)


def _stewart_joint_std_1p3x(mp):
    """One of the joint adjustment's 42 leg parameters' std 1.3 x (its covariance row and
    column)."""

    def scale(cal, *a, **k):
        f = np.ones(len(cal.cov))
        f[6] = 1.3  # leg 1's l
        return dataclasses.replace(cal, cov=cal.cov * np.outer(f, f))

    _wrap(mp, "calibench.estimators.stewart.adjustment", "adjust_jointly", scale)


def _arm_std_1p3x(mp):
    """The arm identification's std of one parameter 1.3 x."""

    def scale(ident, *a, **k):
        name = next(iter(ident.std))  # the first kept parameter
        return dataclasses.replace(ident, std={**ident.std, name: 1.3 * ident.std[name]})

    _wrap(mp, "calibench.estimators.identification.solver", "identify", scale)


def _arm_always_converged(mp):
    """The arm's Levenberg-Marquardt says converged whatever its last iterate (a silent last
    iterate)."""
    from calibench.estimators.identification.solver import Status

    _wrap(
        mp,
        "calibench.estimators.identification.solver",
        "identify",
        lambda ident, *a, **k: dataclasses.replace(ident, status=Status.SMALL_STEP),
    )


KIN = "tests/estimators/test_arm_kinematics.py"
STUDY_TABLE = "tests/scenarios/test_study_table.py"
FAULTS: dict[str, Fault] = {
    "arm_dh_alpha_100urad": Fault(
        "joint 3's nominal alpha 100 urad off in the estimators' chain",
        _arm_nominal(3, 2, 100e-6),
        (f"{KIN}::test_chain_is_mujocos_arm_with_errors",),
    ),
    "arm_dh_alpha_100urad_in_the_run": Fault(
        "the same, seen by the arm-cmm run: its parameters are judged against the injected errors",
        _arm_nominal(3, 2, 100e-6),
        ("tests/scenarios/test_arm_cmm.py::test_run_meets_the_acceptance",),
    ),
    "arm_dh_theta_100urad": Fault(
        "joint 2's nominal theta 100 urad off in the estimators' chain",
        _arm_nominal(2, 3, 100e-6),
        (f"{KIN}::test_chain_is_mujocos_arm_with_errors",),
    ),
    "probe_model_1pct": Fault(
        "the rotary probe's model of the reading (rounded_square_rho) 1 % long",
        _probe_model_1pct,
        (
            "tests/estimators/test_rotary_probe.py::test_lsq_recovers_the_truth_and_its_std_is_honest",
        ),
    ),
    "chessboard_bias_0p03px": Fault(
        "+0.03 px in x on every corner the chessboard detector returns",
        _chessboard_bias,
        (
            "tests/estimators/test_chessboard.py::test_corners_are_found_to_a_twentieth_of_a_pixel",
            "tests/sim/test_camera.py::test_saddle_refinement_beats_cornersubpix_on_renders",
        ),
    ),
    "belt_map_std_1p6x": Fault(
        "the belt stage's reported error-map std (propagated_std, c0..c5 of both axes) 1.6 x",
        _belt_map_std_1p6x,
        ("tests/scenarios/test_belt_stage.py::test_reported_std_is_honest_over_seeds",),
    ),
    "error_map_std_1p6x": Fault(
        "the quadratic map fit's own coefficient std (fit_quadratic) 1.6 x",
        _error_map_std_1p6x,
        (
            "tests/estimators/test_error_map.py::test_recovers_coefficients_within_their_std_and_the_std_is_honest",
        ),
    ),
    "map_xy_term_dropped": Fault(
        "the fitted error map evaluated without its x y term (c4 silently zeroed)",
        _map_xy_term_dropped,
        (
            "tests/estimators/test_error_map.py::test_fitted_map_is_the_truth_between_the_stations",
            "tests/estimators/test_error_map.py::test_compensated_command_lands_on_target",
        ),
    ),
    "gravity_tool_term_dropped": Fault(
        "the tool's weight dropped from the gravity moments the compliance model uses",
        _gravity_tool_term_dropped,
        (f"{KIN}::test_gravity_torques_are_mujocos_inverse_dynamics",),
    ),
    "stewart_leg_std_1p3x": Fault(
        "the one-step leg calibration's std of l (one of 7 parameters) 1.3 x",
        _stewart_leg_std_1p3x,
        ("tests/estimators/test_stewart.py::test_one_step_std_is_honest_per_parameter",),
    ),
    "stewart_joint_std_1p3x": Fault(
        "the joint adjustment's std of leg 1's l (one of 42 parameters) 1.3 x",
        _stewart_joint_std_1p3x,
        (
            "tests/estimators/test_stewart.py::test_joint_adjustment_recovers_the_legs_and_its_std_is_the_bound",
        ),
    ),
    "arm_std_1p3x": Fault(
        "the arm identification's std of its first kept parameter 1.3 x",
        _arm_std_1p3x,
        (
            "tests/estimators/test_arm_identification.py::test_identification_std_is_honest_per_parameter",
        ),
    ),
    "arm_always_converged": Fault(
        "the arm's Levenberg-Marquardt reports converged whatever its last iterate",
        _arm_always_converged,
        (
            "tests/estimators/test_arm_identification.py::test_a_solve_that_cannot_descend_is_not_called_converged",
        ),
    ),
    # --- issue 36: faults a reviewer tried (their apply functions in tests/sabotage_faults.py)
    "stage_locate_p_0p5": Fault(
        "the stages' located structure listed at p <= 0.5, not 0.01 (a null then locates some)",
        more.stage_locate_p_0p5,
        (
            "tests/scenarios/test_discover.py::test_thermal_expansion_without_a_temperature_change_is_called_confounded",
        ),
    ),
    "interferometer_sign_flipped": Fault(
        "the vision stage's interferometer deviations target - actual, ISO 230-2 on them",
        more.interferometer_sign_flipped,
        (
            "tests/scenarios/test_vision_stage.py::test_interferometer_deviations_are_actual_minus_target",
        ),
    ),
    "coverage_z_2p0": Fault(
        "a study's coverage_95 counted within 2.0 std, not 1.96",
        more.coverage_z(2.0),
        ("tests/scenarios/test_montecarlo.py::test_coverage_counts_errors_within_1p96_std",),
    ),
    "coverage_z_1p645": Fault(
        "a study's coverage_95 counted within 1.645 std, not 1.96",
        more.coverage_z(1.645),
        ("tests/scenarios/test_montecarlo.py::test_coverage_counts_errors_within_1p96_std",),
    ),
    "belt_yaw_std_10x": Fault(
        "the belt stage's reported board-yaw std (propagated_std's 13th value) 10 x",
        more.belt_yaw_std_10x,
        (
            "tests/estimators/test_belt_maps.py::test_maps_recover_the_injected_errors_and_yaw_within_their_std",
        ),
    ),
    "arm_tracker_noise_without_distance": Fault(
        "the simulated laser tracker's range noise a alone, without its b L term",
        more.arm_tracker_noise_without_distance,
        ("tests/sim/test_arm_tracker.py::test_range_scatter_grows_with_distance_as_a_plus_b_l",),
    ),
    "stewart_pitch_amplitude_2x": Fault(
        "a Stewart leg's pitch error reported with twice its fitted amplitude",
        more.stewart_pitch_amplitude_2x,
        (
            "tests/estimators/test_discovery.py::test_stewart_pitch_effect_reports_the_injected_amplitude_and_phase",
        ),
    ),
    "stewart_csv_leg_shifted": Fault(
        "a Stewart CSV read back with leg 3's readings 0.1 um long",
        more.stewart_csv_leg_shifted,
        ("tests/test_recordings.py::test_stewart_csv_round_trip_keeps_every_column",),
    ),
    "run_recording_truth_half": Fault(
        "the sealed truth beside a run's recording says half of each concealed effect's size",
        more.run_recording_truth_half,
        (
            "tests/scenarios/test_run_recording.py::"
            "test_a_concealed_effect_is_in_the_run_s_recording_and_discover_finds_it[belt-stage]",
        ),
    ),
    "iso230_two_runs_conform": Fault(
        "ISO 230-2's test taken as met by 2 runs each way",
        more.iso230_two_runs_conform,
        ("tests/scenarios/test_iso230.py::test_a_run_short_of_the_standard_s_five_runs_says_so",),
    ),
    # --- issue 61: the sabotage gaps of discovery's noise, units and look-alikes
    "stage_time_drift_per_minute": Fault(
        "a stage's drift in time (no temperature logged) fitted per minute, said per hour",
        more.stage_time_drift_per_minute,
        ("tests/scenarios/test_discover_time_drift.py",),
    ),
    "confounded_at_0p95": Fault(
        "look-alikes said confounded above 95 % of their columns spanned, not 90 %",
        more.confounded_at_0p95,
        ("tests/estimators/test_discovery_confounds.py",),
    ),
    "stewart_repeat_tol_half": Fault(
        "a Stewart pose's repeats grouped within half the tolerance",
        more.stewart_repeat_tol_half,
        (
            "tests/scenarios/test_discover_repeats.py::"
            "test_every_commanded_repeat_pairs_up_at_the_default_tolerance",
        ),
    ),
    "floor_from_all_repeats": Fault(
        "the verdict's noise floor from every repeat, hours apart too, never successive readings",
        more.floor_from_all_repeats,
        ("tests/scenarios/test_discover_floor.py",),
    ),
    "floor_factor_1p5": Fault(
        "nothing said left until the held-out RMS is 1.5 x the noise floor, not 1.2 x",
        more.floor_factor_1p5,
        ("tests/scenarios/test_discover_drift.py",),
    ),
    "local_judged_on_every_row": Fault(
        "an effect confined to a few rows judged on the whole axis's held-out RMS",
        more.local_judged_on_every_row,
        ("tests/estimators/test_discovery_local.py",),
    ),
    "rival_beaten_by_z_alone": Fault(
        "a mechanism named when it beats its look-alike by 2 standard errors, however little its "
        "held-out RMS is below the look-alike's",
        more.rival_beaten_by_z_alone,
        ("tests/estimators/test_discovery_rivals.py",),
    ),
    "warmup_counted_from_mid_recording": Fault(
        "a Stewart leg's warm-up counted from mid-recording, not from the recording's first time",
        more.warmup_counted_from_mid_recording,
        ("tests/estimators/test_discovery_warmup.py",),
    ),
    "heat_delay_of_one_inverse": Fault(
        "a heat network's mean delay behind a ramp of the air taken as c A^-1 b, not c A^-2 b",
        more.heat_delay_of_one_inverse,
        (
            "tests/sim/test_concealed_simulated.py::test_a_heated_scale_trails_a_ramp_of_the_air_by_its_network_s_mean_delay",
        ),
    ),
    "suite_arm_ignored": Fault(
        "the suites' NAME:ARM cases recorded and searched with the seed's arm",
        more.suite_arm_ignored,
        ("tests/scenarios/test_registry.py::test_a_suite_s_arm_reaches_its_recording",),
    ),
    "count_ignored_on_the_scanner": Fault(
        "the probe scanner's angle table judged without half the reading's count",
        more.count_ignored_on_the_scanner,
        (
            "tests/scenarios/test_discover_simulated.py::"
            "test_nothing_is_claimed_on_quantised_readings[probe-scanner]",
        ),
    ),
    "other_scenarios_table_ignored": Fault(
        "run ignoring a config table of another scenario than the one it runs",
        more.other_scenarios_table_ignored,
        ("tests/test_bad_input.py::test_bad_input[config-other-scenarios-table]",),
    ),
}
# issue 63's, the arm's: kept in their own module within the house's length of a file
FAULTS.update({name: Fault(*spec) for name, spec in ARM_FAULTS.items()})
# issue 64's, uncertainty and acceptance
FAULTS.update({name: Fault(*spec) for name, spec in UNCERTAINTY_FAULTS.items()})

_state: dict = {"name": None, "mp": None, "caught": []}


def pytest_configure(config):
    """Apply the fault named in the environment, if any; refuse an unknown name (usage error)."""
    name = os.environ.get(ENV, "")
    if not name:
        return
    if name not in FAULTS:
        raise pytest.UsageError(f"{ENV}={name!r}: no such fault; one of {', '.join(FAULTS)}")
    mp = pytest.MonkeyPatch()
    FAULTS[name].apply(mp)
    _state.update(name=name, mp=mp)


def pytest_unconfigure(config):
    """Undo the fault."""
    if _state["mp"] is not None:
        _state["mp"].undo()
        _state["mp"] = None


@pytest.hookimpl(wrapper=True)
def pytest_runtest_makereport(item, call):
    """Note the tests an assertion failed in: a fault must be caught by a check, not by a crash."""
    report = yield
    if (
        call.when == "call"
        and report.failed
        and call.excinfo is not None
        and call.excinfo.errisinstance(AssertionError)
    ):
        _state["caught"].append(item.nodeid)
    return report


def pytest_terminal_summary(terminalreporter):
    """Say which fault ran and which tests' assertions caught it (read by
    tests/test_sabotage.py)."""
    name = _state["name"]
    if name is None:
        terminalreporter.write_line("sabotage: no fault applied")
        return
    terminalreporter.write_line(f"sabotage: applied {name}: {FAULTS[name].description}")
    for nodeid in _state["caught"]:
        terminalreporter.write_line(f"sabotage: assertion failed in {nodeid}")
