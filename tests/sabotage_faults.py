"""The faults' tools and more faults for ``tests/sabotage.py`` (issue 36): how a fault replaces a
library function everywhere it is bound, and the newer faults' ``apply(monkeypatch)``, kept here
so that FAULTS, in ``tests/sabotage.py``, stays within the house's length of a file. Each fault
changes one figure, constant or reading by a small, precise amount."""

from __future__ import annotations

import dataclasses
import functools
import importlib
import sys
from collections.abc import Callable

import numpy as np
import pytest


def replace(mp: pytest.MonkeyPatch, module: str, name: str, new) -> None:
    """Set ``module.name`` to ``new``, and every loaded calibench module's own binding of the
    original (``from module import name``): modules imported later take the new one from ``module``.

    Parameters
    ----------
    mp : the session's MonkeyPatch (undone at the end of the session).
    module : dotted name of the module that defines ``name``.
    name : the attribute to replace.
    new : its replacement, usually a wrapper of the original.
    """
    mod = importlib.import_module(module)
    old = getattr(mod, name)
    mp.setattr(mod, name, new)
    for other in list(sys.modules.values()):
        if (
            other is not mod
            and getattr(other, "__name__", "").startswith("calibench.")
            and getattr(other, name, None) is old
        ):
            mp.setattr(other, name, new)


def wrap(mp: pytest.MonkeyPatch, module: str, name: str, change: Callable) -> None:
    """Replace the function ``module.name`` by one that returns ``change(result, *args, **kwargs)``.

    Parameters
    ----------
    mp, module, name : as :func:`replace`.
    change : takes the real function's result (and its arguments) and returns the faulty one.
    """
    real = getattr(importlib.import_module(module), name)

    @functools.wraps(real)
    def faulty(*args, **kwargs):
        return change(real(*args, **kwargs), *args, **kwargs)

    replace(mp, module, name, faulty)


def stage_locate_p_0p5(mp: pytest.MonkeyPatch) -> None:
    """The stages' localisation lists a residual against a driver at p <= 0.5, not 0.01."""
    from calibench.scenarios.stages import discovery_words as stage_words

    mp.setattr(stage_words, "LOCATE_P", 0.5)


def interferometer_sign_flipped(mp: pytest.MonkeyPatch) -> None:
    """The interferometer's deviations target minus actual (each line's, and ISO 230-2's figures
    evaluated on them)."""
    from calibench.estimators.stage import iso230_2

    def flip(lines, *a, **k):
        out = []
        for ln in lines:
            up, down = -ln["dev_up_um"], -ln["dev_down_um"]
            iso = iso230_2.evaluate(ln["targets_mm"], up, down)
            out.append({**ln, "dev_up_um": up, "dev_down_um": down, "iso": iso})
        return out

    wrap(mp, "calibench.scenarios.vision_stage.procedure", "interferometer_test", flip)


def coverage_z(z: float):
    """A fault counting coverage_95 within ``z`` std instead of 1.96."""

    def apply(mp: pytest.MonkeyPatch) -> None:
        from calibench.scenarios.study import summary

        mp.setattr(summary, "Z_95", z)

    return apply


def belt_yaw_std_10x(mp: pytest.MonkeyPatch) -> None:
    """The belt stage's reported board-yaw std (propagated_std's 13th value) 10 x."""

    def inflate(std, *a, **k):
        std = np.array(std, float)
        std[12] *= 10.0
        return std

    wrap(mp, "calibench.estimators.stage.belt_maps", "propagated_std", inflate)


def arm_tracker_noise_without_distance(mp: pytest.MonkeyPatch) -> None:
    """The simulated laser tracker's range noise a, not a + b L (its stated sigma untouched)."""
    from calibench.sim.arm_cmm import ArmSim

    real = ArmSim.tracker

    @functools.wraps(real)
    def tracker(self, q_motor, rng):
        truth = self.truth
        self.truth = dataclasses.replace(truth, range_noise_um=(truth.range_noise_um[0], 0.0))
        try:
            return real(self, q_motor, rng)
        finally:
            self.truth = truth

    mp.setattr(ArmSim, "tracker", tracker)


def stewart_pitch_amplitude_2x(mp: pytest.MonkeyPatch) -> None:
    """A Stewart leg's pitch error reported with twice its fitted amplitude."""
    from calibench.estimators.discovery.stewart import LegPitch

    real = LegPitch.describe

    @functools.wraps(real)
    def describe(self, coef, cov):
        params, std, words = real(self, coef, cov)
        return {**params, "amplitude_mm": 2 * params["amplitude_mm"]}, std, words

    mp.setattr(LegPitch, "describe", describe)


def stewart_csv_leg_shifted(mp: pytest.MonkeyPatch) -> None:
    """A Stewart CSV read back with leg 3's readings 0.1 um long."""

    def shift(rec, *a, **k):
        readings = rec.readings_mm.copy()
        readings[:, 2] += 1e-4
        return dataclasses.replace(rec, readings_mm=readings)

    wrap(mp, "calibench.recordings.stewart", "load_stewart_csv", shift)


def run_recording_truth_half(mp: pytest.MonkeyPatch) -> None:
    """The sealed truth beside a run's recording says half the size of each concealed effect (the
    recording itself untouched)."""

    def halve(out, *a, **k):
        recording, manifest = out
        effects = [
            {
                **e,
                "params": {k: v / 2 if isinstance(v, float) else v for k, v in e["params"].items()},
            }
            for e in manifest.get("effects", [])
        ]
        return recording, {**manifest, "effects": effects}

    wrap(mp, "calibench.scenarios.run_recording", "simulate", halve)


def iso230_two_runs_conform(mp: pytest.MonkeyPatch) -> None:
    """ISO 230-2's test taken as met by 2 runs each way (the standard asks for 5)."""
    from calibench.scenarios import iso230

    mp.setattr(iso230, "RUNS_REQUIRED", 2)


def suite_arm_ignored(mp: pytest.MonkeyPatch) -> None:
    """The suites' ``NAME:ARM`` labels lose their arm: the seed's arm recorded and searched."""
    from calibench.scenarios.discover import suite

    real = suite.recorded

    def recorded(label, kind, seed, **options):
        return real(label.partition(":")[0], kind, seed, **options)

    mp.setattr(suite, "recorded", recorded)


def stage_time_drift_per_minute(mp: pytest.MonkeyPatch) -> None:
    """A stage's drift in time (no temperature logged) fitted per minute, said per hour."""
    from calibench.estimators.discovery.stage import ThermalDrift

    real = ThermalDrift.columns

    @functools.wraps(real)
    def columns(self, d):
        if self.driver != "t_s":
            return real(self, d)
        v = np.asarray(d["t_s"], float) / 60
        return (v - v.mean())[:, None]

    mp.setattr(ThermalDrift, "columns", columns)


def confounded_at_0p95(mp: pytest.MonkeyPatch) -> None:
    """Look-alikes said confounded above 95 % of their columns spanned, not 90 %."""
    from calibench.estimators.discovery import confounds

    real = confounds.find_confounds

    @functools.wraps(real)
    def find(*a, **k):
        if len(a) < 6 and "limit" not in k:
            k["limit"] = 0.95
        return real(*a, **k)

    replace(mp, "calibench.estimators.discovery.confounds", "find_confounds", find)


def stewart_repeat_tol_half(mp: pytest.MonkeyPatch) -> None:
    """A Stewart pose's repeats grouped within half the tolerance (2 sqrt 2 sigma)."""
    from calibench.scenarios.stewart import discovery

    mp.setattr(discovery, "REPEAT_TOL_SIGMA", discovery.REPEAT_TOL_SIGMA / 2)


def floor_from_all_repeats(mp: pytest.MonkeyPatch) -> None:
    """The verdict's noise floor taken from every repeat, hours apart too (the repeatability),
    and never from successive readings."""
    from calibench.estimators.discovery import noise

    real = noise.noise_floor

    @functools.wraps(real)
    def floor(r, order, station=None, passes=None, successive=False, path=None):
        mp.setattr(noise, "SHORTEST_LAGS", 1.0)
        return real(r, order, station, passes, False, path)

    replace(mp, "calibench.estimators.discovery.noise", "noise_floor", floor)


def floor_factor_1p5(mp: pytest.MonkeyPatch) -> None:
    """Nothing said left until the held-out RMS is 1.5 x the floor, not 1.2 x."""
    from calibench.scenarios.discover import report

    mp.setattr(report, "FLOOR_FACTOR", 1.5)


def local_judged_on_every_row(mp: pytest.MonkeyPatch) -> None:
    """An effect confined to a few rows judged on the whole axis's held-out RMS (its rows'
    cut ignored)."""
    replace(mp, "calibench.estimators.discovery.select", "gain_where_it_acts", lambda *a: 0.0)


def rival_beaten_by_z_alone(mp: pytest.MonkeyPatch) -> None:
    """A mechanism named when it beats its strongest look-alike by z alone (no margin)."""
    from calibench.estimators.discovery import rivals

    mp.setattr(rivals, "MARGIN", -np.inf)


def warmup_counted_from_mid_recording(mp: pytest.MonkeyPatch) -> None:
    """A leg's warm-up counted from mid-recording, not from its first time: its shape the same,
    its settled size scaled by exp((t_mid - t_0) / settle_s)."""
    from calibench.estimators.discovery import warmup

    def settling(d, settle_s):
        t = np.asarray(d["t_s"], float)
        s = 1.0 - np.exp(-(t - t.mean()) / settle_s)
        return s - s.mean()

    mp.setattr(warmup, "_settling", settling)


def heat_delay_of_one_inverse(mp: pytest.MonkeyPatch) -> None:
    """A heat network's mean delay taken as c A^-1 b (the steady gain, negated), not c A^-2 b."""
    from calibench.sim.concealed import heat

    mp.setattr(heat, "mean_delay_s", lambda A, b: float(-np.linalg.solve(A, b)[1]))


def count_ignored_on_the_scanner(mp: pytest.MonkeyPatch) -> None:
    """The scanner's angle table judged without the reading's count (half a count of repeatable
    quantisation error taken for a local effect)."""
    from calibench.scenarios.probe_scanner import discovery

    mp.setattr(discovery, "resolution", lambda values: 0.0)


def other_scenarios_table_ignored(mp: pytest.MonkeyPatch) -> None:
    """run's config check taking any scenario's table (the belt stage's, for a vision-stage run)
    as if it were read."""
    from calibench.scenarios import config

    mp.setattr(config, "check_tables", lambda *a: None)
