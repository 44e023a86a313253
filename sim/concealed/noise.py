"""Reading noise for blinded recordings, as assumed or not.

The estimators assume independent Gaussian readings. Real instruments break that: a reading's
tails are heavier (vibration, a dusty scale), the reference drifts slowly between readings (air,
the mount's temperature), and now and then a reading is grossly wrong (a bubble in the beam, a
missed count). The misspecified kinds keep the stated 1-sigma ``sigma`` as the scale of the
reading's own scatter, so a recording states the noise its maker believes in:

- ``gaussian``: N(0, sigma), what every estimator assumes;
- ``t3``: Student t with 3 degrees of freedom, scaled to the standard deviation ``sigma``
  (heavy tails: one reading in 70 beyond 3 sigma, against one in 370);
- ``drift``: N(0, sigma) plus a slow drift, a stationary Ornstein-Uhlenbeck process of standard
  deviation ``sigma`` whose correlation lasts :data:`DRIFT_SHARE` of the recording;
- ``outliers``: N(0, sigma) plus :data:`OUTLIER_SHARE` of readings displaced by 10 to 30 sigma;
- ``quantised`` (the third suite's, kept out of :data:`NOISE_KINDS` so the earlier studies draw
  as they did): an instrument that reports in counts of :data:`QUANTUM_SIGMAS` sigma, its own
  scatter before the count sigma / 2, so a reading's whole scatter is still sigma (a uniform
  count's 3 / sqrt(12) = 0.87 and the half in quadrature). A reading taken again at the same
  place mostly repeats to the count: the scatter that short repeats show is not the reading's.
  :func:`read` applies the count.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import lfilter

NOISE_KINDS = ("gaussian", "t3", "drift", "outliers")
MISSPECIFIED = NOISE_KINDS[1:]
QUANTISED = "quantised"
THIRD_SUITE_NOISES = MISSPECIFIED + (QUANTISED,)
QUANTUM_SIGMAS = 3.0  # a count of the quantised instrument, in sigma
QUANTISED_SCATTER = 0.5  # its scatter before the count, in sigma
DRIFT_SHARE = 0.02  # the drift's correlation length, as a share of the recording's readings
OUTLIER_SHARE = 0.01
OUTLIER_SIGMAS = (10.0, 30.0)


def reading_noise(
    kind: str, rng: np.random.Generator, shape: tuple[int, ...], sigma: float
) -> np.ndarray:
    """Noise of ``kind`` for readings in time order along the first axis.

    Parameters
    ----------
    kind : str
        One of :data:`NOISE_KINDS` or ``quantised`` (the scatter before the count: pass the
        readings through :func:`read`).
    rng : numpy.random.Generator
        The recording's generator; ``gaussian`` draws exactly ``rng.normal(0, sigma, shape)``,
        so recordings made before the other kinds existed are unchanged bit for bit.
    shape : tuple of int
        (n_readings, ...) the noise's shape, readings in time order.
    sigma : float
        The stated 1-sigma of one reading, in the readings' unit.

    Returns
    -------
    ndarray
        ``shape``.
    """
    if kind not in NOISE_KINDS + (QUANTISED,):
        raise ValueError(f"unknown noise {kind!r} (known: {', '.join(NOISE_KINDS)}, {QUANTISED})")
    if kind == QUANTISED:
        return rng.normal(0, QUANTISED_SCATTER * sigma, shape)
    if kind == "t3":
        return sigma / np.sqrt(3.0) * rng.standard_t(3, shape)
    white = rng.normal(0, sigma, shape)
    n = shape[0]
    if kind == "drift":
        a = np.exp(-1.0 / max(DRIFT_SHARE * n, 1.0))
        kick = rng.normal(0, sigma * np.sqrt(1 - a * a), shape)
        kick[0] = rng.normal(0, sigma, shape[1:])  # started in its stationary state
        return white + lfilter([1.0], [1.0, -a], kick, axis=0)
    if kind == "outliers":
        flat = white.reshape(n, -1)
        k = max(1, int(round(OUTLIER_SHARE * flat.size)))
        at = rng.choice(flat.size, k, replace=False)
        jump = rng.uniform(*OUTLIER_SIGMAS, k) * sigma * rng.choice([-1.0, 1.0], k)
        flat.flat[at] += jump
        return flat.reshape(shape)
    return white


def noise_rms(kind: str, sigma: float) -> float:
    """The RMS of ``kind``'s noise at the stated 1-sigma ``sigma``: what the readings truly
    scatter by, the drift's share and the gross readings' included (a verdict's "true noise")."""
    if kind == "drift":  # white and the drift, each of standard deviation sigma
        return float(np.sqrt(2.0) * sigma)
    if kind == "outliers":
        lo, hi = OUTLIER_SIGMAS
        jump2 = (hi**3 - lo**3) / (3 * (hi - lo))  # E[u^2], u uniform on the displacements
        return float(sigma * np.sqrt(1.0 + OUTLIER_SHARE * jump2))
    return float(sigma)  # gaussian, t3 (scaled to sigma), quantised (the count's and before it)


def read(kind: str, values: np.ndarray, sigma: float) -> np.ndarray:
    """What an instrument whose reading noise is ``kind`` reports for ``values`` (any shape),
    its noise already added: the ``quantised`` kind's count (:data:`QUANTUM_SIGMAS` sigma, from
    zero), the others as they are."""
    if kind != QUANTISED:
        return values
    count = QUANTUM_SIGMAS * sigma
    return np.round(np.asarray(values) / count) * count


def repeat_noise(kind: str, rng: np.random.Generator, seed: int, repeat: int):
    """The noise of a recording, or of its ``repeat``-th repeat (the same machine again).

    Returns ``noisy(shape, sigma, kind=kind)``: :func:`reading_noise` drawn from ``rng``, and in
    a repeat (``repeat`` > 0) drawn again from the repeat's own generator and that returned:
    the first recording's draw is made anyway, so every draw of the machine after it stays the
    same (the machine is the same; only its noise is fresh)."""
    again = np.random.default_rng([seed, 100 + repeat]) if repeat else None

    def noisy(shape: tuple[int, ...], sigma: float, of: str = kind) -> np.ndarray:
        first = reading_noise(of, rng, shape, sigma)
        return first if again is None else reading_noise(of, again, shape, sigma)

    return noisy
