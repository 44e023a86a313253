"""Blinded probe-scanner recordings with concealed effects.

Kinds: ``null``, ``runout`` (the table's radial error motion), ``eccentricity`` (the table
encoder's), ``scale`` (the probe's), ``bump`` (a nick in the plate's wall), ``combined`` (runout,
eccentricity and scale), ``drift`` (the probe's mount warming behind the logged air).
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING

import numpy as np

from calibench.recordings import ScannerRecording
from calibench.sim.concealed.effects import effect
from calibench.sim.concealed.heat import SIMULATED_SCANNER_KINDS, heated_mount
from calibench.sim.concealed.noise import read, reading_noise
from calibench.sim.concealed.sessions import (
    first_order_rise,
    manifest,
    room_temperature,
    session_generator,
)
from calibench.sim.concealed.unwritten import UNWRITTEN_SCANNER_KINDS, thin_wall_deflection

SCANNER_KINDS = ("null", "runout", "eccentricity", "scale", "bump", "combined", "drift")
if TYPE_CHECKING:  # the twin's modules import MuJoCo: loaded where a recording is made
    from calibench.sim.probe_scanner import ProbeScannerSim, ProbeScannerTruth

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
      logged temperature (the lag), so no candidate writes it down exactly;
    - ``heated_mount`` (the third suite's): the mount warmed through the probe's column as the
      room warms, both heat capacities integrated in time (``heat.heated_mount``).

    Parameters
    ----------
    kind : str
        One of ``SCANNER_KINDS`` or the second and third suites' kinds (``unwritten``, ``heat``).
    seed : int
        Every draw's seed: the same seed gives the same recording, bit for bit.
    turns : int
        How many turns, each of the scanner's samples per turn.
    noise : str
        The probe's reading noise, one of ``noise.NOISE_KINDS`` or ``noise.QUANTISED``
        (``gaussian``: as assumed).
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
    from calibench.sim.probe_scanner import ProbeScannerSim

    if kind not in SCANNER_KINDS + UNWRITTEN_SCANNER_KINDS + SIMULATED_SCANNER_KINDS:
        raise ValueError(f"unknown kind {kind!r} (known: {', '.join(SCANNER_KINDS)})")
    rng = np.random.default_rng(seed)
    g = geometry or ProbeScannerGeometry()
    turns = DRIFT_TURNS if kind in ("drift",) + SIMULATED_SCANNER_KINDS else turns
    truth = as_built_rail(rng, twin, plate_turn_deg)
    # a turned plate's recording, or a repeat, is another session: its own jitter and noise, the
    # same machine
    phi = np.deg2rad(plate_turn_deg)
    session = session_generator(rng, seed, plate_turn_deg, round(1e6 * phi), repeat)
    sim = ProbeScannerSim(g, truth)
    m = g.samples_per_turn
    nominal = np.tile(np.arange(m) * 2 * np.pi / m, turns)
    turn = np.repeat(np.arange(turns), m)
    wanted = {"combined": ("runout", "eccentricity", "scale")}.get(kind, (kind,))
    effects: list[dict] = []
    true_theta = table_angles(rng, session, sim, nominal, truth.angle_jitter_deg)
    if "eccentricity" in wanted:
        true_theta, eccentric = encoder_eccentricity(rng, true_theta, nominal)
        effects.append(eccentric)
    rho = plate_radius_mm(sim, truth, true_theta)
    form = plate_form_mm(seed, form_um, true_theta, truth.alpha0_rad) if form_um else None
    rho, found = wall_errors(kind, wanted, rng, rho, true_theta, nominal, harmonic, form)
    effects += found
    rho, found = probe_scale(wanted, rng, rho, truth.probe_scale_ppm)
    effects += found
    t = np.arange(len(rho)) * 10.0 / m  # ten seconds a turn
    air, grown, found = thermal_errors(kind, rng, t)
    rho += grown
    effects += found
    rho = probe_readings_mm(rho, noise, session, truth.probe_noise_um, truth.quantum_um)
    rec = ScannerRecording(turn, nominal, rho, t, np.round(air, 3))
    sigma_um = float(np.hypot(truth.probe_noise_um, truth.quantum_um / np.sqrt(12)))
    return rec, manifest(
        "probe-scanner",
        kind,
        seed,
        effects,
        sigma_um,
        noise,
        plate_turn_deg=plate_turn_deg,
        form_um=form_um,
        repeat=repeat,
    )


def as_built_rail(
    rng: np.random.Generator, twin: ProbeScannerTruth | None, plate_turn_deg: float
) -> ProbeScannerTruth:
    """The rail as built and the plate's clamping: d 7.6-8.4 mm, dL 2.7-3.3 mm, alpha0 0.30-0.40
    rad, the plate's centre N(0, 0.1 mm) each axis, drawn about the design (a ``twin``'s own
    instead, drawn all the same: the draws after stay the seed's), the plate turned on the table
    by ``plate_turn_deg``.

    Returns
    -------
    ProbeScannerTruth
        ``twin`` (default: the design's) with the rail and clamping seen from the turned plate.
    """
    from calibench.sim.probe_scanner import ProbeScannerTruth

    d, dL, alpha0, centre = (
        rng.uniform(7.6, 8.4),
        rng.uniform(2.7, 3.3),
        rng.uniform(0.30, 0.40),
        rng.normal(0, 0.1, 2),
    )
    # the plate turned by phi on the table: to the rail it stands as the plate at rest seen from
    # a rail turned back by phi, its clamping offset turned with it
    if twin is not None:
        d, dL, alpha0 = twin.d_mm, twin.dL_mm, twin.alpha0_rad
        centre = np.asarray(twin.plate_centre_mm, float)
    phi = np.deg2rad(plate_turn_deg)
    centre = np.array([[np.cos(phi), -np.sin(phi)], [np.sin(phi), np.cos(phi)]]) @ centre
    return dataclasses.replace(
        twin or ProbeScannerTruth(),
        d_mm=d,
        dL_mm=dL,
        alpha0_rad=alpha0 - phi,
        plate_centre_mm=(float(centre[0]), float(centre[1])),
    )


def table_angles(
    rng: np.random.Generator,
    session: np.random.Generator,
    sim: ProbeScannerSim,
    nominal_rad: np.ndarray,
    jitter_deg: float,
) -> np.ndarray:
    """The table's true angle (n,) rad at the encoder's nominal angles ``nominal_rad`` (n,): the
    twin's own encoder (its eccentricity; none: nominal) and the angle's jitter, drawn from
    ``rng`` and, in another ``session``, drawn again from its generator (the first draw made
    anyway: the machine's draws after it stay the seed's)."""
    jitter = rng.normal(0, np.deg2rad(jitter_deg), len(nominal_rad))
    if session is not rng:
        jitter = session.normal(0, np.deg2rad(jitter_deg), len(nominal_rad))
    return sim.table_angle(nominal_rad) + jitter


def encoder_eccentricity(
    rng: np.random.Generator, theta_rad: np.ndarray, nominal_rad: np.ndarray
) -> tuple[np.ndarray, dict]:
    """The encoder's disc off-centre by 150-400 urad: the table's true angles (n,) rad stand
    short of what the encoder reads, A sin(nominal + phase); and the effect's record."""
    A, ph = rng.uniform(150, 400) * 1e-6, rng.uniform(0, 2 * np.pi)
    theta_rad -= A * np.sin(nominal_rad + ph)  # the encoder reads A sin ahead of the table
    return theta_rad, effect("encoder_eccentricity", "rho", amplitude_urad=A * 1e6)


def plate_radius_mm(
    sim: ProbeScannerSim, truth: ProbeScannerTruth, theta_rad: np.ndarray
) -> np.ndarray:
    """Where the stylus meets the plate's wall at the table's true angles (n,) rad: MuJoCo's ray
    with the twin's own run-out; (n,) mm."""
    rho = sim.exact_rho("plate", theta_rad)
    for k, a, ph in zip(truth.runout_harmonics, truth.runout_mm, truth.runout_phase_rad):
        rho = rho + a * np.sin(round(k) * theta_rad + ph)  # the twin's own run-out
    return rho


def wall_errors(
    kind: str,
    wanted: tuple[str, ...],
    rng: np.random.Generator,
    rho_mm: np.ndarray,
    theta_rad: np.ndarray,
    nominal_rad: np.ndarray,
    harmonic: int | None,
    form_mm: np.ndarray | None,
) -> tuple[np.ndarray, list[dict]]:
    """Where the stylus meets the wall, on its radius ``rho_mm`` (n,) at the table's angles
    ``theta_rad`` (n,): the concealed run-out (2-9 times a turn, not 4 or 8, 3-8 um;
    ``harmonic`` if given) and nick in the wall (10-25 um deep, 0.5-1.5 deg wide) as ``wanted``
    and ``kind`` ask, the plate's own form ``form_mm`` (n,) (None: none), and the second suite's
    thin wall (``kind`` ``thin_wall``: no candidate writes it down); the radius and the effects'
    records."""
    effects = []
    if "runout" in wanted:
        # not 4 or 8: a square artefact cannot show a fourfold runout (discover says so)
        k, A, ph = (
            int(rng.choice([2, 3, 5, 6, 7, 9])),
            rng.uniform(3, 8) / 1000,
            rng.uniform(0, 2 * np.pi),
        )
        k = k if harmonic is None else int(harmonic)
        rho_mm -= A * np.sin(k * theta_rad + ph)
        effects.append(effect("runout", "rho", harmonic=k, amplitude_mm=A))
    if kind == "bump":
        th0, w, h = rng.uniform(0, 360), rng.uniform(0.5, 1.5), rng.uniform(10, 25) / 1000
        dist = (np.degrees(nominal_rad) - th0 + 180) % 360 - 180
        rho_mm += h * np.exp(-0.5 * (dist / w) ** 2)  # the stylus drops into the nick
        effects.append(effect("nonsmooth", "rho", theta_deg=th0, width_deg=w, depth_mm=h))
    if form_mm is not None:
        rho_mm += form_mm
    if kind == "thin_wall":
        push, truth_wall = thin_wall_deflection(rng, theta_rad)
        rho_mm += push
        effects.append(truth_wall)
    return rho_mm, effects


def plate_form_mm(
    seed: int, form_um: float, theta_rad: np.ndarray, alpha0_rad: float
) -> np.ndarray:
    """The plate's own form error at the table's angles (n,) rad: its wall off by ``form_um``
    four times around, turning with the plate, its phase from the seed alone (the same plate in
    every session); (n,) mm."""
    psi = np.random.default_rng([seed, 7]).uniform(0, 2 * np.pi)
    return form_um / 1000 * np.sin(4 * (theta_rad + alpha0_rad) + psi)


def probe_scale(
    wanted: tuple[str, ...], rng: np.random.Generator, rho_mm: np.ndarray, twin_ppm: float
) -> tuple[np.ndarray, list[dict]]:
    """The probe's scale: the twin's own ``twin_ppm``, then the concealed one (0.1-0.3 % long)
    where ``wanted``; the radius (n,) mm as read, and the effect's record."""
    if twin_ppm:
        rho_mm = rho_mm * (1 + twin_ppm * 1e-6)
    if "scale" not in wanted:
        return rho_mm, []
    s = rng.uniform(1000, 3000)
    rho_mm *= 1 + s * 1e-6
    return rho_mm, [effect("scale", "rho", ppm=s)]


def thermal_errors(
    kind: str, rng: np.random.Generator, t_s: np.ndarray
) -> tuple[np.ndarray, np.ndarray, list[dict]]:
    """The room's logged temperature (n,) deg C and how far the probe's zero moves with it (n,)
    mm: a ``drift``'s mount lagging the air, a ``heated_mount`` warmed through the probe's
    column (the third suite's, its heat integrated in time); nothing for the other kinds. With
    the effects' truths."""
    air = room_temperature(rng, len(t_s), 1e-3)
    if kind == "drift":
        air, grown, drift = mount_drift(rng, t_s, air)
        return air, grown, [drift]
    if kind in SIMULATED_SCANNER_KINDS:
        grown, heated, air = heated_mount(rng, t_s, air)
        return air, grown, [heated]
    return air, np.zeros(len(t_s)), []


def mount_drift(
    rng: np.random.Generator, t_s: np.ndarray, air_c: np.ndarray
) -> tuple[np.ndarray, np.ndarray, dict]:
    """The room warming 1-2 K (a first-order rise, 20-60 s) and the probe's mount following the
    air with its own lag (25-60 s), its growth moving the probe's zero 4-8 um per kelvin.

    Returns
    -------
    air_c : ndarray
        (n,) the logged air, deg C.
    drift_mm : ndarray
        (n,) the probe's zero, mm.
    effect : dict
        The effect's record.
    """
    rise, tau_air = rng.uniform(1.0, 2.0), rng.uniform(20, 60)
    air_c = air_c + first_order_rise(t_s, rise, tau_air)
    tau_mount, k = rng.uniform(25, 60), rng.uniform(4, 8) / 1000
    # the mount's temperature: the air's, through a first-order lag (exact per sample step)
    a = np.exp(-np.diff(t_s, prepend=t_s[0]) / tau_mount)
    mount = np.empty_like(air_c)
    mount[0] = air_c[0]
    for i in range(1, len(air_c)):
        mount[i] = a[i] * mount[i - 1] + (1 - a[i]) * air_c[i]
    return air_c, k * (mount - mount[0]), effect("thermal_drift", "rho", mm_per_k=k)


def probe_readings_mm(
    rho_mm: np.ndarray,
    noise: str,
    session: np.random.Generator,
    noise_um: float,
    quantum_um: float,
) -> np.ndarray:
    """What the probe reads of the radius (n,) mm: its noise of kind ``noise`` and 1-sigma
    ``noise_um``, drawn from the ``session``'s generator, then its linear encoder's quantum."""
    q = quantum_um / 1000
    read_mm = read(
        noise,
        rho_mm + reading_noise(noise, session, rho_mm.shape, noise_um / 1000),
        noise_um / 1000,
    )
    return np.round(read_mm / q) * q
