"""Blinded Stewart platform recordings with concealed effects.

Kinds: ``null``, ``thermal`` (a leg's growth), ``backlash`` (a leg's lost motion), ``pitch`` (a
leg's screw), ``compliance`` (the legs shortened by their axial loads, by MuJoCo's statics).
"""

from __future__ import annotations

import numpy as np

from calibench.recordings import StewartRecording
from calibench.sim.concealed.noise import repeat_noise
from calibench.sim.concealed.unwritten import (
    UNWRITTEN_STEWART_KINDS,
    stewart_effect,
    tracker_air,
)
from calibench.sim.stewart import leg_effects_mm, stewart_poses

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
        One of ``STEWART_KINDS`` or of the second suite's ``unwritten.UNWRITTEN_STEWART_KINDS``.
    seed : int
        Every draw's seed: the same seed gives the same recording, bit for bit.
    n_poses : int
        How many poses (each visited twice: the recording has 2 ``n_poses`` rows).
    noise : str
        The legs' and the tracker's reading noise, one of ``noise.NOISE_KINDS`` (``gaussian``:
        as assumed).
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
    from scipy.spatial.transform import Rotation

    from calibench.scenes.stewart import StewartGeometry
    from calibench.sim.stewart import StewartSim, StewartTruth

    if kind not in STEWART_KINDS + UNWRITTEN_STEWART_KINDS:
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
    L = np.empty((n, 6))
    force = np.zeros((n, 6))
    for k, (R, t) in enumerate(poses):
        sim.set_pose(R, t)
        L[k] = sim.leg_lengths_mm()
        if kind == "compliance":
            force[k] = sim.leg_forces_n(R, t, load[k])
    step = np.diff(np.vstack([L[:1] - 1.0, L]), axis=0)  # homed from below
    direction = np.sign(step)
    t_s = np.arange(n) * 30.0
    T = 20.0 + np.cumsum(rng.normal(0, 0.002, n))
    readings = L - sim.l0
    leg = int(rng.integers(1, 7))
    effects = []
    T_ref, T = T[0], T + warmer_k
    if kind == "thermal":
        rise, k = rng.uniform(2, 5), rng.uniform(10, 25)
        rise = rise if rise_k is None else rise_k
        T = T + rise * (1 - np.exp(-t_s / (t_s[-1] / 2)))
        readings[:, leg - 1] -= k * 1e-6 * (T - T_ref) * L[:, leg - 1]
        effects.append(
            {"name": "thermal_expansion", "axis": "legs", "params": {"leg": leg, "ppm_per_k": k}}
        )
    if kind == "backlash":
        B = rng.uniform(5, 15) / 1000
        readings[:, leg - 1] += B / 2 * direction[:, leg - 1]
        effects.append(
            {"name": "backlash", "axis": "legs", "params": {"leg": leg, "reversal_mm": B}}
        )
    if kind == "pitch":
        P, A, ph = rng.uniform(4, 12), rng.uniform(3, 8) / 1000, rng.uniform(0, 2 * np.pi)
        readings[:, leg - 1] += A * np.sin(2 * np.pi * L[:, leg - 1] / P + ph)
        effects.append(
            {
                "name": "periodic",
                "axis": "legs",
                "params": {"leg": leg, "period_mm": P, "amplitude_mm": A},
            }
        )
    if kind == "compliance":
        c = rng.uniform(0.02, 0.05)
        readings += (
            c * (1 + 0.05 * rng.standard_normal(6)) * 1e-3 * force
        )  # the screw reads what the leg gave
        effects.append({"name": "leg_compliance", "axis": "legs", "params": {"um_per_n": c}})
    if twin.has_leg_physics:  # the twin's own legs, under the payload the recording says
        pushed = np.array([sim.leg_forces_n(R, t, load[k]) for k, (R, t) in enumerate(poses)])
        readings += leg_effects_mm(twin, L, pushed, direction, T)
    if kind in UNWRITTEN_STEWART_KINDS and kind != "tracker_air":  # the second suite's
        more, truth = stewart_effect(kind, rng, direction, leg, t_s)
        readings += more
        effects.append(truth)
    readings += noisy(readings.shape, 1e-3)
    # the tracker's frame: turned about the vertical and set beside the machine
    R_tr = Rotation.from_rotvec(
        np.r_[rng.normal(0, 0.01, 2), rng.uniform(-np.pi, np.pi)]
    ).as_matrix()
    t_tr = np.r_[rng.uniform(1500, 3000), rng.uniform(-1000, 1000), rng.uniform(-800, 0)]
    # the tracker's noise, in time order: (n, reflectors, 3)
    tracker_noise = noisy((n, len(g.reflectors_mm), 3), 2e-3)
    range_scale = np.zeros(n)  # the tracker's distances read long by this share
    if kind == "tracker_air":
        T, range_scale, distance, truth = tracker_air(rng, T, t_s)
        t_tr = t_tr * distance / np.linalg.norm(t_tr)  # set back along the same bearing
        effects.append(truth)
    R_meas, t_meas = np.empty((n, 3, 3)), np.empty((n, 3))
    for k, (R, t) in enumerate(poses):
        world = g.reflectors_mm @ R.T + t
        seen = (world @ R_tr.T + t_tr) * (1 + range_scale[k]) + tracker_noise[k]
        # the tracker's own pose solution (scipy's Kabsch, not the estimators')
        c_seen, c_refl = seen.mean(axis=0), g.reflectors_mm.mean(axis=0)
        R_meas[k] = Rotation.align_vectors(seen - c_seen, g.reflectors_mm - c_refl)[0].as_matrix()
        t_meas[k] = c_seen - R_meas[k] @ c_refl
    rec = StewartRecording(
        np.round(readings, 6), R_meas, t_meas, t_s, np.round(T, 3), direction, load
    )
    # per leg: the reading's 1 um and the tracker's pose (its reflectors' 2 um, levered out to the
    # hinges) together, as the repeats show it
    return rec, {
        "scenario": "stewart",
        "kind": kind,
        "seed": seed,
        "effects": effects,
        "noise_um": 2.3,
        "noise": noise,
        "repeat": repeat,
    }
