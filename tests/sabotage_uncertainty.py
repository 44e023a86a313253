"""Issue 64's faults, uncertainty and acceptance, for ``tests/sabotage.py``: the study's coverage
band on its values and at its edge, the uncertainty study's interval, stop, journal and GUM
factor, and the standards' figures (ISO 9283's RP, ISO 10360-12's L_Dia, ISO 230-2's R). Each
entry of :data:`UNCERTAINTY_FAULTS` is a ``Fault``'s (description, apply, targets)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from tests.sabotage_faults import replace

STUDY_TABLE = "tests/scenarios/test_study_table.py"
STUDY = "tests/scenarios/test_uncertainty_study.py"
JCGM = "tests/estimators/test_uncertainty_jcgm101.py"


def coverage_band_90(mp: pytest.MonkeyPatch) -> None:
    """A study's coverage band from Binomial(n, 0.95)'s 5 % and 95 % quantiles, not 2.5 % and
    97.5 %: the band where an honest std lands 90 % of the time, called 95 %."""
    from calibench.scenarios.study.summary import binom_ppf

    def band(trials):
        n = max(int(trials), 1)
        lo, hi = binom_ppf(np.array([0.05, 0.95]), n, 0.95) / n
        return float(lo), float(hi)

    replace(mp, "calibench.scenarios.study.summary", "coverage_band", band)


def band_edge_outside(mp: pytest.MonkeyPatch) -> None:
    """A coverage on the band's edge counted outside (< for <=)."""
    replace(mp, "calibench.scenarios.study.summary", "in_band", lambda c, b: bool(b[0] < c < b[1]))


def iso9283_rp_two_sigma(mp: pytest.MonkeyPatch) -> None:
    """ISO 9283's repeatability RP taken as l_mean + 2 S_l, not + 3 S_l."""
    from calibench.scenarios.arm_cmm import acceptance

    def figures(attained, commanded):
        mean = attained.mean(axis=0)
        l_j = np.linalg.norm(attained - mean, axis=2)
        ap = np.linalg.norm(mean - commanded, axis=1)
        return ap, l_j.mean(axis=0) + 2 * l_j.std(axis=0, ddof=1)

    mp.setattr(acceptance, "pose_figures", figures)


def uncertainty_interval_90(mp: pytest.MonkeyPatch) -> None:
    """The uncertainty study's interval taken at 90 % and stated as its 95 % one."""
    from calibench.scenarios import uncertainty

    real = uncertainty.coverage_interval
    mp.setattr(uncertainty, "coverage_interval", lambda values, p, **kw: real(values, 0.90, **kw))


def adaptive_stop_at_s(mp: pytest.MonkeyPatch) -> None:
    """The adaptive procedure's stop when s <= delta, not 2 s <= delta (7.9.4 k): it stops with
    half the numerical confidence it states."""
    from calibench.estimators.uncertainty import adaptive

    real = adaptive._ratio
    mp.setattr(adaptive, "_ratio", lambda two_s, tol: real(two_s / 2, tol))


def journal_of_another_study(mp: pytest.MonkeyPatch) -> None:
    """An uncertainty study's journal read whole: the trials of another study (another seed) in
    the same directory taken for its own."""
    from calibench.scenarios import uncertainty

    real = uncertainty.load_trials

    def load(out, key):
        path = out / uncertainty.JOURNAL
        if not path.exists():
            return real(out, key)
        keys = {line.split('"study": "')[1][:16] for line in path.read_text().splitlines() if line}
        done = {}
        for k in sorted(keys):
            done.update(real(out, k))
        return done

    mp.setattr(uncertainty, "load_trials", load)


def gum_factor_two(mp: pytest.MonkeyPatch) -> None:
    """The GUM framework's coverage factor taken as 2 at 95 %, not 1.96 (a Gaussian's)."""
    from calibench.estimators.uncertainty import gum

    real = gum.coverage_factor
    replace(
        mp,
        "calibench.estimators.uncertainty.gum",
        "coverage_factor",
        lambda p=0.95, dof=None: 2.0 if dof is None and p == 0.95 else real(p, dof),
    )


def l_dia_as_radius(mp: pytest.MonkeyPatch) -> None:
    """ISO 10360-12's L_Dia as the largest distance of a location from their mean, a radius."""
    from calibench.scenarios.arm_cmm import iso10360

    real = iso10360.figures

    def figures(bars, ends, centres, probed):
        out = real(bars, ends, centres, probed)
        return {**out, "L_Dia_um": out["L_Dia_um"] / 2}

    mp.setattr(iso10360, "figures", figures)


def iso230_2_repeatability_two_s(mp: pytest.MonkeyPatch) -> None:
    """ISO 230-2's unidirectional repeatability as 2 s, not 4 s."""
    from calibench.estimators.stage import iso230_2

    real = iso230_2.evaluate

    def evaluate(targets, dev_up, dev_down):
        r = real(targets, dev_up, dev_down)
        return dataclasses.replace(
            r, R_up_i=r.R_up_i / 2, R_down_i=r.R_down_i / 2, R_up=r.R_up / 2, R_down=r.R_down / 2
        )

    replace(mp, "calibench.estimators.stage.iso230_2", "evaluate", evaluate)


def recording_rp_two_sigma(mp: pytest.MonkeyPatch) -> None:
    """A recording's pooled RP as E[l_mean + 2 S_l], not + 3 S_l."""

    def rp(cov_mm2, cycles=30, draws=20_000, seed=9283):
        L = np.linalg.cholesky(np.asarray(cov_mm2, float) + 1e-30 * np.eye(3))
        x = np.random.default_rng(seed).standard_normal((draws, cycles, 3)) @ L.T
        l_j = np.linalg.norm(x - x.mean(axis=1, keepdims=True), axis=2)
        return float(np.mean(l_j.mean(axis=1) + 2 * l_j.std(axis=1, ddof=1)))

    replace(mp, "calibench.estimators.arm.repeatability", "expected_rp", rp)


def stale_repeats_pooled(mp: pytest.MonkeyPatch) -> None:
    """A recording's stale and disagreeing readings pooled into its repeatability."""
    from calibench.estimators.arm import screening

    real = screening.screen

    def screen(*args, **kwargs):
        s = real(*args, **kwargs)
        return dataclasses.replace(s, stale=s.stale[:0], pairs=s.pairs[:0])

    replace(mp, "calibench.estimators.arm.screening", "screen", screen)


def belt_maps_cov_diagonal(mp: pytest.MonkeyPatch) -> None:
    """The belt stage's maps' covariance without its correlations (the std alone)."""
    from calibench.estimators.stage import belt_maps

    real = belt_maps.propagated_cov

    def cov(*args, **kwargs):
        return np.diag(np.diag(real(*args, **kwargs)))

    replace(mp, "calibench.estimators.stage.belt_maps", "propagated_cov", cov)


UNCERTAINTY_FAULTS = {
    "coverage_band_90": (
        "the study's coverage band from the 5 % and 95 % quantiles, not 2.5 % and 97.5 %",
        coverage_band_90,
        (f"{STUDY_TABLE}::test_the_coverage_band_is_the_binomial_scatter_of_an_honest_std",),
    ),
    "band_edge_outside": (
        "a coverage on the band's edge counted outside",
        band_edge_outside,
        (
            f"{STUDY_TABLE}::test_a_coverage_on_the_band_s_edge_is_inside_in_the_summary_and_the_figure",
        ),
    ),
    "iso9283_rp_two_sigma": (
        "ISO 9283's RP with two standard deviations of the distances, not three",
        iso9283_rp_two_sigma,
        ("tests/scenarios/test_acceptance.py::test_iso9283_figures_of_a_known_scatter",),
    ),
    "uncertainty_interval_90": (
        "the uncertainty study's 95 % interval taken at 90 %",
        uncertainty_interval_90,
        (f"{STUDY}::test_the_study_states_the_law_it_samples",),
    ),
    "adaptive_stop_at_s": (
        "JCGM 101's adaptive stop at s <= delta, not 2 s <= delta",
        adaptive_stop_at_s,
        (f"{JCGM}::test_the_adaptive_stop_keeps_its_promise",),
    ),
    "journal_of_another_study": (
        "an uncertainty study resuming from another study's journaled trials",
        journal_of_another_study,
        (f"{STUDY}::test_a_journal_of_another_seed_is_not_taken_for_this_studys",),
    ),
    "gum_factor_two": (
        "the GUM framework's 95 % coverage factor taken as 2, not 1.96",
        gum_factor_two,
        (f"{JCGM}::test_9_2_2_gaussian_inputs_table_2",),
    ),
    "l_dia_as_radius": (
        "ISO 10360-12's L_Dia as the locations' radius, not their diameter",
        l_dia_as_radius,
        ("tests/scenarios/test_acceptance.py::test_iso10360_12_figures_of_known_measurements",),
    ),
    "iso230_2_repeatability_two_s": (
        "ISO 230-2's unidirectional repeatability as 2 s, not 4 s",
        iso230_2_repeatability_two_s,
        ("tests/estimators/test_iso230_2.py",),
    ),
    "recording_rp_two_sigma": (
        "a recording's pooled RP with two standard deviations of the distances, not three",
        recording_rp_two_sigma,
        (
            "tests/estimators/test_arm_repeatability.py::"
            "test_expected_rp_is_iso9283s_rp_of_that_scatter",
        ),
    ),
    "stale_repeats_pooled": (
        "a recording's stale and disagreeing readings pooled into its RP",
        stale_repeats_pooled,
        (
            "tests/scenarios/test_acceptance_recording.py::"
            "test_the_real_ur10s_rp_is_within_its_makers_figure",
        ),
    ),
    "belt_maps_cov_diagonal": (
        "the belt stage's maps' covariance without its correlations",
        belt_maps_cov_diagonal,
        (
            "tests/scenarios/test_uncertainty_tasks.py::"
            "test_the_stage_tasks_gum_u_is_its_trials_spread",
        ),
    ),
}
