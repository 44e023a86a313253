"""The probe scanner's twin updated on top of the replayed one
(scenarios/probe_scanner/discovery_twin.py): what discover finds against a twin is what that
twin left, so the written twin must read as the old twin's effects plus the found ones."""

import numpy as np

from calibench.scenarios.probe_scanner.discovery_twin import twin_table

RAIL = {"d_mm": 1.0, "dL_mm": 0.1, "alpha0_rad": 0.2, "plate_centre_mm": [0.0, 0.0]}


def _runout(truth: dict, theta: np.ndarray) -> np.ndarray:
    """The scanner simulation's run-out at table angles ``theta`` (sim/probe_scanner.py)."""
    return sum(
        a * np.sin(k * theta + ph)
        for k, a, ph in zip(
            truth["runout_harmonics"], truth["runout_mm"], truth["runout_phase_rad"]
        )
    )


def test_found_effects_add_to_the_twin_s_own():
    """A twin with a 2nd-harmonic run-out, an eccentricity and a scale; discover finds more of
    the 2nd harmonic, a 3rd, more eccentricity and scale: the written run-out is the sum of both
    at every angle (to rounding), the 3rd harmonic as found, the eccentricity the phasor sum
    and the scale the ppm sum; the config's other entries and the calibrated rail carried."""
    rng = np.random.default_rng(3)
    given = {
        "runout_harmonics": [2],
        "runout_mm": [0.012],
        "runout_phase_rad": [0.4],
        "encoder_eccentricity_urad": 30.0,
        "encoder_eccentricity_phase_rad": -1.0,
        "probe_scale_ppm": 12.0,
        "d_mm": 0.9,  # the rail, recalibrated below
        "some_other_entry": 7.0,
    }
    found = [
        ("runout", {"harmonic": 2, "amplitude_mm": 0.004, "phase_rad": 2.1}),
        ("runout", {"harmonic": 3, "amplitude_mm": 0.002, "phase_rad": -0.3}),
        ("encoder_eccentricity", {"amplitude_urad": 10.0, "phase_rad": 0.7}),
        ("scale", {"ppm": -5.0}),
    ]
    out = {"twin_rail": RAIL, "effects": [{"name": n, "params": p} for n, p in found]}
    truth = twin_table(out, given)["probe-scanner"]["truth"]
    theta = rng.uniform(0, 2 * np.pi, 100)
    both = _runout(given, theta) + sum(
        p["amplitude_mm"] * np.sin(p["harmonic"] * theta + p["phase_rad"])
        for n, p in found
        if n == "runout"
    )
    np.testing.assert_allclose(_runout(truth, theta), both, rtol=0, atol=1e-15)
    ecc = 30.0 * np.exp(-1j) + 10.0 * np.exp(0.7j)
    assert np.isclose(truth["encoder_eccentricity_urad"], abs(ecc), rtol=1e-12)
    assert np.isclose(truth["encoder_eccentricity_phase_rad"], np.angle(ecc), rtol=1e-12)
    assert truth["probe_scale_ppm"] == 7.0
    assert truth["some_other_entry"] == 7.0 and truth["d_mm"] == RAIL["d_mm"]


def test_without_a_twin_the_effects_are_written_as_found():
    out = {
        "twin_rail": RAIL,
        "effects": [
            {"name": "runout", "params": {"harmonic": 1, "amplitude_mm": 0.01, "phase_rad": 4.0}},
            {"name": "encoder_eccentricity", "params": {"amplitude_urad": 9.0, "phase_rad": 5.0}},
        ],
    }
    truth = twin_table(out)["probe-scanner"]["truth"]
    assert truth["runout_harmonics"] == [1] and truth["runout_phase_rad"] == [4.0]
    assert truth["encoder_eccentricity_urad"] == 9.0
    assert truth["encoder_eccentricity_phase_rad"] == 5.0
    assert "probe_scale_ppm" not in truth
