"""Blinded Stewart platform recordings with concealed effects.

Kinds: ``null``, ``thermal`` (a leg's growth), ``backlash`` (a leg's lost motion), ``pitch`` (a
leg's screw), ``compliance`` (the legs shortened by their axial loads, by MuJoCo's statics).
"""

from __future__ import annotations

import numpy as np

from calibench.recordings import StewartRecording
from calibench.sim.concealed.effects import (
    draw_lost_motion_mm,
    draw_periodic,
    effect,
    expansion_mm,
    lost_motion_mm,
    periodic_mm,
)
from calibench.sim.concealed.heat import SIMULATED_STEWART_KINDS, heated_leg
from calibench.sim.concealed.noise import read, repeat_noise
from calibench.sim.concealed.sessions import first_order_rise, manifest, room_temperature
from calibench.sim.concealed.unwritten import (
    UNWRITTEN_STEWART_KINDS,
    stewart_effect,
    tracker_air,
)
from calibench.sim.stewart import StewartSim, leg_effects_mm, stewart_poses

STEWART_KINDS = ("null", "thermal", "backlash", "pitch", "compliance")
# The Stewart scenario's default working range about home (its StewartConfig's), fixed here: the
# proof set does not move with the scenario's config.
STEWART_TRANSLATION_MM = 150.0
STEWART_ROTATION_DEG = 10.0


def stewart_recording(
    kind: str,
    seed: int,
    n_poses: int = 100,
    noise: str = "gaussian",
    repeat: int = 0,
    rise_k: float | None = None,
    warmer_k: float = 0.0,
    twin=None,
    geometry=None,
) -> tuple[StewartRecording, dict]:
    """A blinded Stewart recording: ``n_poses`` poses visited, then visited again in reverse
    order (so every leg approaches each pose both ways), a payload of 0, 500 or 1000 N on the
    platform in turn, the platform as built (hinge errors of the scenario's size), the tracker
    in a frame of its own measuring three reflectors (2 um per coordinate), the legs' readings
    1 um, with the concealed effect of ``kind``:

    - ``thermal``: one leg grows 10-25 ppm/K, the temperature rising 2-5 K;
    - ``backlash``: one leg's drive loses 5-15 um on reversal;
    - ``pitch``: one leg's screw is off periodically, lead 4-12 mm, 3-8 um;
    - ``compliance``: every leg gives 0.02-0.05 um per N (each within 5 % of the others) of the
      axial force MuJoCo's statics put on it.

    Parameters
    ----------
    kind : str
        One of ``STEWART_KINDS``, of the second suite's ``unwritten.UNWRITTEN_STEWART_KINDS`` or
        the third's ``heat.SIMULATED_STEWART_KINDS``.
    seed : int
        Every draw's seed: the same seed gives the same recording, bit for bit.
    n_poses : int
        How many poses (each visited twice: the recording has 2 ``n_poses`` rows).
    noise : str
        The legs' and the tracker's reading noise, one of ``noise.NOISE_KINDS`` (``gaussian``:
        as assumed) or ``quantised`` (the legs' readings in counts).
    repeat : int
        The same platform recorded again at the same poses from the same tracker station: its
        errors the same draws, the legs' and the tracker's noise fresh (``k`` > 0: the ``k``-th
        repeat; 0: the first).
    rise_k : float or None
        ``thermal``: how far the temperature rises during the recording, K (None: drawn, 2-5).
    warmer_k : float
        The room this much warmer than on the first recording, K (with ``repeat``: the same
        platform recorded warm; its legs' growth counts from the first recording's start).
    twin : StewartTruth or None
        The twin recorded (a ``run --config`` file's: its hinge errors' size, its legs' physics,
        the compliance under the recording's own ``load_n``); None: the default. The concealed
        effect is added on top of it.
    geometry : StewartGeometry or None
        The platform's design (a ``[stewart.geometry]`` table's); None: the default.

    Returns
    -------
    recording : StewartRecording
        readings_mm (n, 6), the tracker's pose R (n, 3, 3) and t_mm (n, 3), directions (n, 6),
        the load (n,) N.
    manifest : dict
        The sealed truth: scenario, kind, seed, the effects with their parameters, the noise in
        um.

    Raises
    ------
    ValueError
        An unknown kind.
    """
    from calibench.scenes.stewart import StewartGeometry
    from calibench.sim.stewart import StewartTruth

    if kind not in STEWART_KINDS + UNWRITTEN_STEWART_KINDS + SIMULATED_STEWART_KINDS:
        raise ValueError(f"unknown kind {kind!r} (known: {', '.join(STEWART_KINDS)})")
    rng = np.random.default_rng(seed)
    noisy = repeat_noise(noise, rng, seed, repeat)
    g = geometry or StewartGeometry()
    twin = twin or StewartTruth()
    sim = StewartSim(g, twin, rng)
    poses = stewart_poses(n_poses, rng, g, STEWART_TRANSLATION_MM, STEWART_ROTATION_DEG)
    poses = poses + poses[::-1]
    n = len(poses)
    load = 500.0 * (np.arange(n) % 3)
    L, force = leg_lengths_and_forces(sim, poses, load, kind in ("compliance", "heated_leg"))
    step = np.diff(np.vstack([L[:1] - 1.0, L]), axis=0)  # homed from below
    direction = np.sign(step)
    t_s = np.arange(n) * 30.0
    T = room_temperature(rng, n, 0.002)
    readings = L - sim.l0
    leg = int(rng.integers(1, 7))
    T_ref, T = T[0], T + warmer_k
    readings, T, effects = concealed_leg_errors(
        kind, rng, leg, readings, L, direction, force, T, T_ref, t_s, rise_k
    )
    if twin.has_leg_physics:  # the twin's own legs, under the payload the recording says
        pushed = np.array([sim.leg_forces_n(R, t, load[k]) for k, (R, t) in enumerate(poses)])
        readings += leg_effects_mm(twin, L, pushed, direction, T)
    if kind in UNWRITTEN_STEWART_KINDS and kind != "tracker_air":  # the second suite's
        more, truth = stewart_effect(kind, rng, direction, leg, t_s)
        readings += more
        effects.append(truth)
    if kind in SIMULATED_STEWART_KINDS:  # the third suite's: a motor's heat, integrated
        short, truth = heated_leg(rng, t_s, force, L, leg)
        readings[:, leg - 1] -= short
        effects.append(truth)
    readings = read(noise, readings + noisy(readings.shape, 1e-3), 1e-3)
    R_tr, t_tr = tracker_station(rng)
    # the tracker's noise, in time order: (n, reflectors, 3)
    tracker_noise = noisy((n, len(g.reflectors_mm), 3), 2e-3)
    range_scale = np.zeros(n)  # the tracker's distances read long by this share
    if kind == "tracker_air":
        T, range_scale, distance, truth = tracker_air(rng, T, t_s)
        t_tr = t_tr * distance / np.linalg.norm(t_tr)  # set back along the same bearing
        effects.append(truth)
    R_meas, t_meas = tracker_poses(poses, g.reflectors_mm, R_tr, t_tr, range_scale, tracker_noise)
    rec = StewartRecording(
        np.round(readings, 6), R_meas, t_meas, t_s, np.round(T, 3), direction, load
    )
    # per leg: the reading's 1 um and the tracker's pose (its reflectors' 2 um, levered out to the
    # hinges) together, as the repeats show it
    return rec, manifest("stewart", kind, seed, effects, 2.3, noise, repeat=repeat)


def leg_lengths_and_forces(
    sim: StewartSim, poses: list, load_n: np.ndarray, forces: bool
) -> tuple[np.ndarray, np.ndarray]:
    """The legs' true lengths (n, 6) mm at the ``poses`` (n of (R (3, 3), t (3,) mm)), and with
    ``forces`` the axial forces (n, 6) N MuJoCo's statics put on them under the payload
    ``load_n`` (n,) (without: zeros)."""
    n = len(poses)
    L = np.empty((n, 6))
    force = np.zeros((n, 6))
    for k, (R, t) in enumerate(poses):
        sim.set_pose(R, t)
        L[k] = sim.leg_lengths_mm()
        if forces:
            force[k] = sim.leg_forces_n(R, t, load_n[k])
    return L, force


def concealed_leg_errors(
    kind: str,
    rng: np.random.Generator,
    leg: int,
    readings_mm: np.ndarray,
    L_mm: np.ndarray,
    direction: np.ndarray,
    force_n: np.ndarray,
    temp_c: np.ndarray,
    reference_c: float,
    t_s: np.ndarray,
    rise_k: float | None,
) -> tuple[np.ndarray, np.ndarray, list[dict]]:
    """The concealed effect of ``kind`` on the legs' readings ``readings_mm`` (n, 6) (in place).

    ``thermal``: leg ``leg`` (1-6) grows 10-25 ppm/K of its length ``L_mm`` (n, 6) from
    ``reference_c`` while the temperature ``temp_c`` (n,) rises 2-5 K (``rise_k`` if given)
    over the times ``t_s`` (n,); ``backlash``: it loses 5-15 um on reversal of its
    ``direction`` (n, 6); ``pitch``: its screw is off periodically (lead 4-12 mm, 3-8 um);
    ``compliance``: every leg gives 0.02-0.05 um per N (each within 5 % of the others) of its
    axial force ``force_n`` (n, 6).

    Returns
    -------
    readings_mm : ndarray
        (n, 6) mm.
    temp_c : ndarray
        (n,) the logged temperature, deg C.
    effects : list of dict
        The effect's record (none for another kind).
    """
    i = leg - 1
    if kind == "thermal":
        rise, k = rng.uniform(2, 5), rng.uniform(10, 25)
        rise = rise if rise_k is None else rise_k
        temp_c = temp_c + first_order_rise(t_s, rise, t_s[-1] / 2)
        readings_mm[:, i] -= expansion_mm(k, temp_c, reference_c, L_mm[:, i])
        return readings_mm, temp_c, [effect("thermal_expansion", "legs", leg=leg, ppm_per_k=k)]
    if kind == "backlash":
        B = draw_lost_motion_mm(rng)
        readings_mm[:, i] += lost_motion_mm(B, direction[:, i])
        return readings_mm, temp_c, [effect("backlash", "legs", leg=leg, reversal_mm=B)]
    if kind == "pitch":
        P, A, ph = draw_periodic(rng, (4, 12), (3, 8))
        readings_mm[:, i] += periodic_mm(L_mm[:, i], P, A, ph)
        found = effect("periodic", "legs", leg=leg, period_mm=P, amplitude_mm=A)
        return readings_mm, temp_c, [found]
    if kind == "compliance":
        c = rng.uniform(0.02, 0.05)
        # the screw reads what the leg gave
        readings_mm += c * (1 + 0.05 * rng.standard_normal(6)) * 1e-3 * force_n
        return readings_mm, temp_c, [effect("leg_compliance", "legs", um_per_n=c)]
    return readings_mm, temp_c, []


def tracker_station(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """The tracker's frame: turned about the vertical (and tilted by N(0, 0.01 rad)) and set
    beside the machine, 1.5-3 m off; its rotation (3, 3) and translation (3,) mm."""
    from scipy.spatial.transform import Rotation

    R_tr = Rotation.from_rotvec(
        np.r_[rng.normal(0, 0.01, 2), rng.uniform(-np.pi, np.pi)]
    ).as_matrix()
    t_tr = np.r_[rng.uniform(1500, 3000), rng.uniform(-1000, 1000), rng.uniform(-800, 0)]
    return R_tr, t_tr


def tracker_poses(
    poses: list,
    reflectors_mm: np.ndarray,
    R_tr: np.ndarray,
    t_tr_mm: np.ndarray,
    range_scale: np.ndarray,
    noise_mm: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """The platform's poses as the tracker solves them from its reflectors.

    Parameters
    ----------
    poses : list of (ndarray, ndarray)
        n true poses, R (3, 3) and t (3,) mm.
    reflectors_mm : ndarray
        (r, 3) the reflectors on the platform, mm.
    R_tr, t_tr_mm : ndarray
        (3, 3), (3,) the tracker's frame.
    range_scale : ndarray
        (n,) the share its distances read long by.
    noise_mm : ndarray
        (n, r, 3) its noise per reflector, mm.

    Returns
    -------
    R : ndarray
        (n, 3, 3) the poses' rotations in the tracker's frame.
    t_mm : ndarray
        (n, 3) their translations, mm.
    """
    from scipy.spatial.transform import Rotation

    n = len(poses)
    R_meas, t_meas = np.empty((n, 3, 3)), np.empty((n, 3))
    for k, (R, t) in enumerate(poses):
        world = reflectors_mm @ R.T + t
        seen = (world @ R_tr.T + t_tr_mm) * (1 + range_scale[k]) + noise_mm[k]
        # the tracker's own pose solution (scipy's Kabsch, not the estimators')
        c_seen, c_refl = seen.mean(axis=0), reflectors_mm.mean(axis=0)
        R_meas[k] = Rotation.align_vectors(seen - c_seen, reflectors_mm - c_refl)[0].as_matrix()
        t_meas[k] = c_seen - R_meas[k] @ c_refl
    return R_meas, t_meas
