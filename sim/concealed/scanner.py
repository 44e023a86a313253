"""Blinded probe-scanner recordings with concealed effects.

Kinds: ``null``, ``runout`` (the table's radial error motion), ``eccentricity`` (the table
encoder's), ``scale`` (the probe's), ``bump`` (a nick in the plate's wall), ``combined`` (runout,
eccentricity and scale), ``drift`` (the probe's mount warming behind the logged air).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from calibench.recordings import ScannerRecording
from calibench.sim.concealed.noise import reading_noise
from calibench.sim.concealed.unwritten import UNWRITTEN_SCANNER_KINDS, thin_wall_deflection

SCANNER_KINDS = ("null", "runout", "eccentricity", "scale", "bump", "combined", "drift")
DRIFT_TURNS = 8  # a drift shows over turns: the drift recordings are twice as long


def scanner_recording(
    kind: str,
    seed: int,
    turns: int = 4,
    noise: str = "gaussian",
    plate_turn_deg: float = 0.0,
    harmonic: int | None = None,
    form_um: float = 0.0,
    repeat: int = 0,
    twin=None,
    geometry=None,
) -> tuple[ScannerRecording, dict]:
    """A blinded probe-scanner recording: ``turns`` turns over the calibration plate, the rail
    as built (its d, dL, alpha0 and the plate's clamping drawn about the design), each reading
    MuJoCo's ray at the table's true angle, with the concealed effect of ``kind``:

    - ``runout``: the table's bearing moves radially along the rail, a whole number of times
      per turn (2-9, not 4 or 8), 3-8 um: the stylus starts that much further out;
    - ``eccentricity``: the encoder's disc off-centre, 150-400 urad: the table stands short of
      what the encoder reads;
    - ``scale``: the probe's linear encoder reads 0.1-0.3 % long;
    - ``bump``: a nick in the plate's wall 10-25 um deep, 0.5-1.5 deg wide;
    - ``combined``: runout, eccentricity and scale together;
    - ``drift``: the room warms 1-2 K over the recording (a first-order rise); the probe's
      mount follows the air with its own lag (25-60 s) and its growth moves the probe's zero by
      4-8 um per kelvin of the mount: the zero drifts turn after turn, not linearly in the
      logged temperature (the lag), so no candidate writes it down exactly.

    Parameters
    ----------
    kind : str
        One of ``SCANNER_KINDS`` or of the second suite's ``unwritten.UNWRITTEN_SCANNER_KINDS``.
    seed : int
        Every draw's seed: the same seed gives the same recording, bit for bit.
    turns : int
        How many turns, each of the scanner's samples per turn.
    noise : str
        The probe's reading noise, one of ``noise.NOISE_KINDS`` (``gaussian``: as assumed).
    plate_turn_deg : float
        The plate turned on the table by this much about the table's axis (its clamping offset
        turned with it): a second recording of the same machine, its errors the same draws, its
        angle jitter and reading noise fresh. 0: the recording as always.
    harmonic : int or None
        The ``runout``'s harmonic (4: the one the square's own form looks like); None: drawn.
    form_um : float
        The plate's own form error: its wall off by this much, four times around the plate (its
        sides bowed), turning with the plate; the twin's plate is perfect. 0: none.
    repeat : int
        The same machine and plate recorded again: its errors and the room the same draws, its
        angle jitter and reading noise fresh (``k`` > 0: the ``k``-th repeat; 0: the first).
    twin : ProbeScannerTruth or None
        The twin scanned (a ``run --config`` file's: its rail, its plate's clamping, its
        run-out, eccentricity and scale, its probe's noise); None: a rail drawn about the
        design. The concealed effect is added on top of it.
    geometry : ProbeScannerGeometry or None
        The scanner's design (its plate, its samples per turn); None: the default.

    Returns
    -------
    recording : ScannerRecording
        (n,) each field; the encoder's nominal angles, the probe's quantised readings (mm).
    manifest : dict
        The sealed truth: scenario, kind, seed, the effects with their parameters, the probe's
        noise in um.

    Raises
    ------
    ValueError
        An unknown kind.
    """
    from calibench.scenes.probe_scanner import ProbeScannerGeometry
    from calibench.sim.probe_scanner import ProbeScannerSim, ProbeScannerTruth

    if kind not in SCANNER_KINDS + UNWRITTEN_SCANNER_KINDS:
        raise ValueError(f"unknown kind {kind!r} (known: {', '.join(SCANNER_KINDS)})")
    rng = np.random.default_rng(seed)
    g = geometry or ProbeScannerGeometry()
    turns = DRIFT_TURNS if kind == "drift" else turns
    d, dL, alpha0, centre = (
        rng.uniform(7.6, 8.4),
        rng.uniform(2.7, 3.3),
        rng.uniform(0.30, 0.40),
        rng.normal(0, 0.1, 2),
    )
    # the plate turned by phi on the table: to the rail it stands as the plate at rest seen from
    # a rail turned back by phi, its clamping offset turned with it
    if twin is not None:  # the twin's rail (drawn all the same: the draws after stay the seed's)
        d, dL, alpha0, centre = twin.d_mm, twin.dL_mm, twin.alpha0_rad, twin.plate_centre_mm
    phi = np.deg2rad(plate_turn_deg)
    centre = np.array([[np.cos(phi), -np.sin(phi)], [np.sin(phi), np.cos(phi)]]) @ centre
    truth = dataclasses.replace(
        twin or ProbeScannerTruth(),
        d_mm=d,
        dL_mm=dL,
        alpha0_rad=alpha0 - phi,
        plate_centre_mm=tuple(float(v) for v in centre),
    )
    # a turned plate's recording, or a repeat, is another session: its own jitter and noise, the
    # same machine
    session = rng
    if plate_turn_deg or repeat:
        again = [100 + repeat] if repeat else []
        session = np.random.default_rng([seed, 1 + round(1e6 * phi), *again])
    sim = ProbeScannerSim(g, truth)
    m = g.samples_per_turn
    nominal = np.tile(np.arange(m) * 2 * np.pi / m, turns)
    turn = np.repeat(np.arange(turns), m)
    wanted = {"combined": ("runout", "eccentricity", "scale")}.get(kind, (kind,))
    effects = []
    jitter = rng.normal(0, np.deg2rad(truth.angle_jitter_deg), len(nominal))
    if session is not rng:
        jitter = session.normal(0, np.deg2rad(truth.angle_jitter_deg), len(nominal))
    true_theta = sim.table_angle(nominal) + jitter  # the twin's own eccentricity (none: nominal)
    if "eccentricity" in wanted:
        A, ph = rng.uniform(150, 400) * 1e-6, rng.uniform(0, 2 * np.pi)
        true_theta -= A * np.sin(nominal + ph)  # the encoder reads A sin ahead of the table
        effects.append(
            {"name": "encoder_eccentricity", "axis": "rho", "params": {"amplitude_urad": A * 1e6}}
        )
    rho = sim.exact_rho("plate", true_theta)
    for k, a, ph in zip(truth.runout_harmonics, truth.runout_mm, truth.runout_phase_rad):
        rho = rho + a * np.sin(round(k) * true_theta + ph)  # the twin's own run-out
    if "runout" in wanted:
        # not 4 or 8: a square artefact cannot show a fourfold runout (discover says so)
        k, A, ph = (
            int(rng.choice([2, 3, 5, 6, 7, 9])),
            rng.uniform(3, 8) / 1000,
            rng.uniform(0, 2 * np.pi),
        )
        k = k if harmonic is None else int(harmonic)
        rho -= A * np.sin(k * true_theta + ph)
        effects.append(
            {"name": "runout", "axis": "rho", "params": {"harmonic": k, "amplitude_mm": A}}
        )
    if kind == "bump":
        th0, w, h = rng.uniform(0, 360), rng.uniform(0.5, 1.5), rng.uniform(10, 25) / 1000
        dist = (np.degrees(nominal) - th0 + 180) % 360 - 180
        rho += h * np.exp(-0.5 * (dist / w) ** 2)  # the stylus drops into the nick
        effects.append(
            {
                "name": "nonsmooth",
                "axis": "rho",
                "params": {"theta_deg": th0, "width_deg": w, "depth_mm": h},
            }
        )
    if form_um:  # the same plate in every session: its phase from the seed alone
        psi = np.random.default_rng([seed, 7]).uniform(0, 2 * np.pi)
        rho += form_um / 1000 * np.sin(4 * (true_theta + truth.alpha0_rad) + psi)
    if kind == "thin_wall":  # the second suite's: no candidate writes it down
        push, truth_wall = thin_wall_deflection(rng, true_theta)
        rho += push
        effects.append(truth_wall)
    if truth.probe_scale_ppm:  # the twin's own scale
        rho = rho * (1 + truth.probe_scale_ppm * 1e-6)
    if "scale" in wanted:
        s = rng.uniform(1000, 3000)
        rho *= 1 + s * 1e-6
        effects.append({"name": "scale", "axis": "rho", "params": {"ppm": s}})
    t = np.arange(len(rho)) * 10.0 / m  # ten seconds a turn
    air = 20.0 + np.cumsum(rng.normal(0, 1e-3, len(rho)))
    if kind == "drift":
        rise, tau_air = rng.uniform(1.0, 2.0), rng.uniform(20, 60)
        air += rise * (1 - np.exp(-t / tau_air))
        tau_mount, k = rng.uniform(25, 60), rng.uniform(4, 8) / 1000
        # the mount's temperature: the air's, through a first-order lag (exact per sample step)
        a = np.exp(-np.diff(t, prepend=t[0]) / tau_mount)
        mount = np.empty_like(air)
        mount[0] = air[0]
        for i in range(1, len(air)):
            mount[i] = a[i] * mount[i - 1] + (1 - a[i]) * air[i]
        rho += k * (mount - mount[0])
        effects.append({"name": "thermal_drift", "axis": "rho", "params": {"mm_per_k": k}})
    q = truth.quantum_um / 1000
    rho = (
        np.round((rho + reading_noise(noise, session, rho.shape, truth.probe_noise_um / 1000)) / q)
        * q
    )
    rec = ScannerRecording(turn, nominal, rho, t, np.round(air, 3))
    sigma_um = float(np.hypot(truth.probe_noise_um, truth.quantum_um / np.sqrt(12)))
    return rec, {
        "scenario": "probe-scanner",
        "kind": kind,
        "seed": seed,
        "effects": effects,
        "noise_um": sigma_um,
        "noise": noise,
        "plate_turn_deg": plate_turn_deg,
        "form_um": form_um,
        "repeat": repeat,
    }
