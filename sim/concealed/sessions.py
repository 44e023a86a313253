"""What the blinded generators share: a session's own generator, the room's temperature and the
sealed manifest.

Every generator draws the machine from its seed's generator first; a second session of the same
machine (a warmer room, a turned plate, a repeat) draws its noise, and whatever else is fresh,
from a generator of its own, so that the machine's draws stay those of the seed.
"""

from __future__ import annotations

import numpy as np

ROOM_C = 20.0  # the room's temperature at the start of a recording, deg C


def session_generator(
    rng: np.random.Generator, seed: int, setting: float, key: int, repeat: int
) -> np.random.Generator:
    """The generator of a session's fresh draws.

    Parameters
    ----------
    rng : numpy.random.Generator
        The seed's generator, the machine's draws.
    seed : int
        The recording's seed.
    setting : float
        What sets this session apart from the seed's first (a warmer room, K; a turned plate,
        rad); 0: none.
    key : int
        ``setting`` as a whole number that names the session (e.g. ``round(1000 * warmer_k)``).
    repeat : int
        The repeat's number (0: the first recording).

    Returns
    -------
    numpy.random.Generator
        ``rng`` itself for the seed's first recording (no setting, no repeat); else one keyed by
        ``[seed, 1 + key]`` and, in a repeat, ``100 + repeat``.
    """
    if not (setting or repeat):
        return rng
    again = [100 + repeat] if repeat else []
    return np.random.default_rng([seed, 1 + key, *again])


def room_temperature(
    rng: np.random.Generator, n: int, step_k: float, start_c: float = ROOM_C
) -> np.ndarray:
    """A quiet room's logged temperature: a random walk from ``start_c``.

    Parameters
    ----------
    rng : numpy.random.Generator
        Draws ``rng.normal(0, step_k, n)``.
    n : int
        Readings, in time order.
    step_k : float
        The walk's 1-sigma step between readings, K.
    start_c : float
        Where it starts, deg C.

    Returns
    -------
    ndarray
        (n,) deg C.
    """
    return start_c + np.cumsum(rng.normal(0, step_k, n))


def first_order_rise(t_s: np.ndarray, rise_k: float, tau_s: float) -> np.ndarray:
    """A temperature's first-order rise toward ``rise_k`` with time constant ``tau_s``.

    Parameters
    ----------
    t_s : ndarray
        (n,) time, s.
    rise_k : float
        The rise it tends to, K.
    tau_s : float
        Its time constant, s.

    Returns
    -------
    ndarray
        (n,) the rise at each time, K.
    """
    return rise_k * (1 - np.exp(-t_s / tau_s))


def manifest(
    scenario: str,
    kind: str,
    seed: int,
    effects: list[dict],
    noise_um: float,
    noise: str,
    **session: float,
) -> dict:
    """The sealed truth of a recording: scenario, kind, seed, the effects, the stated 1-sigma
    of a reading (um), the noise's kind and the session's settings (in the order given)."""
    return {
        "scenario": scenario,
        "kind": kind,
        "seed": seed,
        "effects": effects,
        "noise_um": noise_um,
        "noise": noise,
        **session,
    }
