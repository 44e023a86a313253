"""Blinded arm recordings (any arm description; the seed's arm CMM and the UR10 in the suite) with
concealed effects.

Kinds: ``null``, ``eccentricity`` (one joint's encoder), ``thermal`` (the links' growth),
``compliance`` (joints giving way under gravity, by MuJoCo's physics), ``transmission`` (one
joint's gear train); the second suite's (``sim.concealed.unwritten``) and the third's, simulated
in MuJoCo (``sim.concealed.simulated``).
"""

from __future__ import annotations

import dataclasses
from typing import Any

import numpy as np

from calibench.errors import BadInput
from calibench.recordings import ArmRecording
from calibench.scenes.arm_cmm import DEFAULT_ARM
from calibench.sim.concealed.noise import read, repeat_noise
from calibench.sim.concealed.simulated import (
    SIMULATED_ARM_KINDS,
    encoder_slip,
    gear_play_angles,
)
from calibench.sim.concealed.unwritten import (
    UNWRITTEN_ARM_KINDS,
    bent_link_points,
    harmonic_drive_angles,
    pedestal_warmup_points,
)

ARM_KINDS = ("null", "eccentricity", "thermal", "compliance", "transmission")


def arm_recording(
    kind: str,
    seed: int,
    n: int = 300,
    noise_um: float = 10.0,
    arm: str = DEFAULT_ARM,
    joint: int | None = None,
    harmonic: float | None = None,
    phase_rad: float | None = None,
    amplitude_urad: float | None = None,
    noise: str = "gaussian",
    repeat: int = 0,
    machine: int = 0,
    truth=None,
) -> tuple[ArmRecording, dict]:
    """A blinded arm recording: the twin with its default as-built errors (Table 1 for the seed's
    arm), probed at ``n`` postures by a reference of ``noise_um`` 1-sigma per coordinate that
    reports in its own frame (a tracker's), with the concealed effect of ``kind``:

    - ``eccentricity``: one joint's encoder disc off-centre (the reading is off once per turn);
    - ``transmission``: one joint's gear train off periodically, 8-40 cycles per turn (not a
      whole number: a reduction's ratio);
    - ``thermal``: the links and tool grow with the logged temperature;
    - ``compliance``: the two most loaded joints given way under gravity (stiffness drawn so the
      largest sag is 100-300 urad), the links settled where MuJoCo's physics puts them;
    - the second suite's ``harmonic_drive`` (:func:`unwritten.harmonic_drive_angles`) and
      ``link_bending`` (:func:`unwritten.bent_link_points`).

    Parameters
    ----------
    kind : str
        One of ``ARM_KINDS``.
    seed : int
        Every draw's seed: the same seed gives the same recording, bit for bit.
    n : int
        How many postures.
    noise_um : float
        The reference's 1-sigma per coordinate, um.
    arm : str
        The arm's description (a built-in name or an ARM.toml path).
    joint : int or None
        The eccentric (or geared) joint, 1-based; None: drawn.
    harmonic, phase_rad, amplitude_urad : float or None
        The gear's cycles per turn, phase (rad) and amplitude (urad); None: each drawn (given,
        sessions of one gear train can be recorded).
    noise : str
        The reference's reading noise, one of ``noise.NOISE_KINDS`` (``gaussian``: as stated)
        or ``quantised``.
    repeat : int
        The same arm probed again at the same postures: its errors the same draws, the encoders'
        and the reference's noise fresh (``k`` > 0: the ``k``-th repeat; 0: the first).
    machine : int
        Which arm of the description's drawing: 0 the one with its default as-built errors,
        ``k`` > 0 another, its errors drawn with seed ``k`` (``sim.arm_cmm.drawn_errors``).
    truth : ArmTruth or None
        The twin probed (a ``run --config`` file's: its chain's errors, its joints' stiffness,
        its tracker); None: the description's as given by ``machine``. The concealed effect is
        added on top of it.

    Returns
    -------
    recording : ArmRecording
        q_rad (n, n_joints) the encoders' readings, xyz_mm (n, 3) in the reference's frame.
    manifest : dict
        The sealed truth: scenario, arm, kind, seed, the effects with their parameters, the
        reference noise in um.

    Raises
    ------
    ValueError
        An unknown kind.
    BadInput
        ``compliance`` on an arm without masses.
    """
    from calibench.scenes.arm_cmm import load_arm
    from calibench.sim.arm_cmm import ArmSim, ArmTruth, drawn_errors

    if kind not in ARM_KINDS + UNWRITTEN_ARM_KINDS + SIMULATED_ARM_KINDS:
        known = ARM_KINDS + UNWRITTEN_ARM_KINDS + SIMULATED_ARM_KINDS
        raise ValueError(f"unknown kind {kind!r} (known: {', '.join(known)})")
    rng = np.random.default_rng(seed)
    description = load_arm(arm)
    if truth is None:
        truth = ArmTruth(delta=drawn_errors(description, machine) if machine else ())
    sim = ArmSim(description, truth)
    q = sim.random_postures(n, rng)
    t = np.arange(n) * 20.0
    T = 20.0 + np.cumsum(rng.normal(0, 0.002, n))
    noisy = repeat_noise(noise, rng, seed, repeat)
    q_read = q + noisy(q.shape, truth.encoder_noise_urad * 1e-6, "gaussian")
    # the arm stands where it stands; its encoders read it off
    off, effects = _read_off(kind, q, t, rng, joint, (harmonic, phase_rad, amplitude_urad))
    q_read += off
    T, xyz, placed = _probed_points(kind, sim, truth, q, t, T, rng)
    effects += placed
    R, p = truth.tracker2base()
    xyz = (xyz - p) @ R  # the instrument reports in its own frame
    xyz = read(noise, xyz + noisy(xyz.shape, noise_um / 1000), noise_um / 1000)
    return (
        ArmRecording(q_read, xyz, t, np.round(T, 3)),
        {
            "scenario": "arm-cmm",
            "arm": description.name,
            "kind": kind,
            "seed": seed,
            "effects": effects,
            "noise_um": noise_um,
            "noise": noise,
            "repeat": repeat,
            "machine": machine,
        },
    )


def _read_off(
    kind: str, q: np.ndarray, t: np.ndarray, rng: np.random.Generator, joint, gear: tuple
) -> tuple[np.ndarray, list[dict[str, Any]]]:
    """What the encoders of an arm at angles ``q`` (n, N) rad read off (n, N) rad, and the
    effects: an eccentric disc, a gear train's harmonic (``gear``: its harmonic, phase and
    amplitude, each None to draw), a disc that slipped once (the third suite's, by MuJoCo)."""
    off = np.zeros_like(q)
    N = q.shape[1]
    if kind in ("eccentricity", "transmission"):
        j, off_rad, effect = (
            _eccentric_encoder(q, rng, N, joint)
            if kind == "eccentricity"
            else _geared_joint(q, rng, N, joint, *gear)
        )
        off[:, j - 1] = off_rad
        return off, [effect]
    if kind == "encoder_slip":
        off, effect = encoder_slip(t, N, rng)
        return off, [effect]
    return off, []


def _probed_points(
    kind: str, sim, truth, q: np.ndarray, t: np.ndarray, T: np.ndarray, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray, list[dict[str, Any]]]:
    """Where the twin puts the probe at motor angles ``q`` (n, N) rad, in the arm's base frame:
    the logged temperature (n,) degC (``T`` unless the links grow with it), the points (n, 3) mm
    and the effects of ``kind`` on them (none but the rigid drawing's for the others)."""
    if kind == "thermal":
        T, xyz, effect = _grown_points(sim, truth, q, t, T, rng)
        return T, xyz, [effect]
    if kind == "compliance":
        xyz, effects = _sagged_points(sim, truth, q, rng)
        return T, xyz, effects
    if kind in UNWRITTEN_ARM_KINDS:  # the second suite's: no candidate writes it down
        xyz, effect = _unwritten_points(kind, sim, q, t, rng)
        return T, xyz, [effect]
    if kind == "gear_play":  # the third suite's: the play's contacts and friction, by MuJoCo
        if not sim.arm.has_masses:
            raise BadInput(f"the arm {sim.arm.name} has no masses: no load on its gears")
        q_link, effect = gear_play_angles(sim, q, rng)
        return T, sim.point_mm(q_link), [effect]
    return T, sim.probe_mm(q), []


def _eccentric_encoder(
    q: np.ndarray, rng: np.random.Generator, n_joints: int, joint: int | None
) -> tuple[int, np.ndarray, dict[str, Any]]:
    """One joint's encoder disc off-centre (``joint``, 1-based; None: drawn, as are the
    amplitude, 300-600 urad, and the phase): the joint, its reading's error (n,) rad at the
    motor angles ``q`` (n, N) rad, and the effect as the manifest says it."""
    j, A, ph = (
        int(rng.integers(1, n_joints + 1)),
        rng.uniform(300, 600) * 1e-6,
        rng.uniform(0, 2 * np.pi),
    )
    j = joint or j  # drawn all the same: a given joint leaves the other draws where they were
    effect = {
        "name": "encoder_eccentricity",
        "axis": "xyz",
        "params": {"joint": j, "amplitude_urad": A * 1e6, "phase_rad": ph},
    }
    return j, A * np.sin(q[:, j - 1] + ph), effect


def _geared_joint(
    q: np.ndarray,
    rng: np.random.Generator,
    n_joints: int,
    joint: int | None,
    harmonic: float | None,
    phase_rad: float | None,
    amplitude_urad: float | None,
) -> tuple[int, np.ndarray, dict[str, Any]]:
    """One joint's gear train off periodically, 8-40 cycles per turn (not a whole number: a
    reduction's ratio), 150-300 urad: the joint, its reading's error (n,) rad at the motor
    angles ``q`` (n, N) rad, and the effect as the manifest says it. Each of ``joint``,
    ``harmonic``, ``phase_rad`` and ``amplitude_urad`` given is used instead of its draw."""
    j = joint or int(rng.integers(1, n_joints + 1))
    h, A, ph = rng.uniform(8, 40), rng.uniform(150, 300) * 1e-6, rng.uniform(0, 2 * np.pi)
    h = h if harmonic is None else harmonic
    ph = ph if phase_rad is None else phase_rad
    A = A if amplitude_urad is None else amplitude_urad * 1e-6
    effect = {
        "name": "transmission",
        "axis": "xyz",
        "params": {"joint": j, "harmonics": [h], "amplitude_urad": [A * 1e6], "phase_rad": ph},
    }
    return j, A * np.sin(h * q[:, j - 1] + ph), effect


def _grown_points(
    sim, truth, q: np.ndarray, t: np.ndarray, T: np.ndarray, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray, dict[str, Any]]:
    """The links and tool grown with the temperature (a rise of 2-5 K over the recording, 10-25
    ppm/K): the logged temperature (n,) degC, the probe points (n, 3) mm in the arm's base
    frame, each posture on the arm as long as it then was, and the effect."""
    from calibench.sim.arm_cmm import ArmSim

    description, N, n = sim.arm, sim.arm.n_joints, len(q)
    rise, k = rng.uniform(2, 5), rng.uniform(10, 25)
    T = T + rise * (1 - np.exp(-t / (t[-1] / 2)))
    effect = {
        "name": "thermal_expansion",
        "axis": "xyz",
        "params": {"ppm_per_k": k},
        "temperature_rise_k": rise,
    }
    xyz = np.empty((n, 3))
    base = sim.delta
    lengths = np.zeros(5 * N + 3)
    lengths[0 : 5 * N : 5] = np.asarray(description.a_mm) + base[0 : 5 * N : 5]
    lengths[1 : 5 * N : 5] = np.asarray(description.d_mm) + base[1 : 5 * N : 5]
    lengths[5 * N :] = np.asarray(description.tool_mm) + base[5 * N :]
    for i in range(n):
        delta = base + k * 1e-6 * (T[i] - T[0]) * lengths
        grown = ArmSim(description, dataclasses.replace(truth, delta=tuple(delta)))
        xyz[i] = grown.probe_mm(q[i : i + 1])[0]
    return T, xyz, effect


def _sagged_points(
    sim, truth, q: np.ndarray, rng: np.random.Generator
) -> tuple[np.ndarray, list[dict[str, Any]]]:
    """The two most loaded joints given way under gravity (stiffness drawn so the largest sag
    is 100-300 urad): the probe points (n, 3) mm where MuJoCo's physics settles the links, and
    the effects."""
    from calibench.sim.arm_cmm import ArmSim

    description = sim.arm
    if not description.has_masses:
        raise BadInput(f"the arm {description.name} has no masses: no compliance under gravity")
    tau = np.abs(sim.gravity_torques(q)).max(axis=0)
    joints = np.sort(np.argsort(-tau)[:2]) + 1
    stiffness = np.full(description.n_joints, np.inf)  # N m / rad
    effects = []
    for j in joints:
        stiffness[j - 1] = tau[j - 1] / (rng.uniform(100, 300) * 1e-6)
        effects.append(
            {
                "name": "joint_compliance",
                "axis": "xyz",
                "params": {"joint": int(j), "urad_per_nm": 1e6 / stiffness[j - 1]},
            }
        )
    compliant = ArmSim(
        description, dataclasses.replace(truth, stiffness_nm_per_rad=tuple(stiffness))
    )
    return compliant.probe_mm(q), effects  # MuJoCo's gravity torques, the links at equilibrium


def _unwritten_points(
    kind: str, sim, q: np.ndarray, t: np.ndarray, rng: np.random.Generator
) -> tuple[np.ndarray, dict[str, Any]]:
    """The second suite's effects, which no candidate writes down: the probe points (n, 3) mm
    and the effect (:mod:`calibench.sim.concealed.unwritten`)."""
    if kind == "pedestal_warmup":  # an exponential in time
        return pedestal_warmup_points(sim, q, t, rng)
    if not sim.arm.has_masses:
        raise BadInput(f"the arm {sim.arm.name} has no masses: no load on its gears")
    if kind == "harmonic_drive":
        q_link, effect = harmonic_drive_angles(sim, q, rng)
        return sim.probe_mm(q_link), effect
    return bent_link_points(sim, q, rng)
