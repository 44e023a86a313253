"""A Stewart leg's reading that settles after power-on: the warm-up's time constant and size
found (``estimators/discovery/warmup.py``, issue 61).

The truth is a heat network's, integrated in time (``sim/concealed/heat.py``): a motor of time
constant 15 min warmed from the first pose by a constant loss, a leg tube of small capacity
following it 20 s behind, the leg's reading short by its growth (20 um when settled), 200 poses
30 s apart, 1 um of noise. The network's slow pole is the settling's time constant; its fast
pole adds a settling of its own that a single exponential does not write: about 20 s on the
time constant and 20 / 900 of the size, beside 3 standard errors of each."""

import numpy as np

from calibench.estimators.discovery.warmup import LegWarmup, LegWarmupSearch
from calibench.sim.concealed import heat

NOISE_MM = 0.001
SETTLED_MM = 0.020
LEG = 2


def _recording(seed: int):
    rng = np.random.default_rng(seed)
    t = np.arange(200) * 30.0
    A, b = heat.network(900.0, 20.0, 0.0, 0.01)
    loss = np.ones(len(t))  # switched on at the first pose
    warm = heat.thin_temperature(t, np.zeros(len(t)), A, b, loss / 900.0)
    steady = float((-np.linalg.solve(A, np.array([1 / 900.0, 0.0])))[1])
    reading = np.zeros((len(t), 6))
    reading[:, LEG - 1] = -SETTLED_MM * warm / steady
    reading += rng.normal(0, NOISE_MM, reading.shape)
    slow = 1 / np.min(np.abs(np.linalg.eigvals(A)))
    return reading.ravel(), {"t_s": t}, slow


def _found(seed: int):
    r, drivers, slow = _recording(seed)
    offsets = np.kron(np.ones((len(r) // 6, 1)), np.eye(6))  # each leg's own zero
    rows = np.ones(len(r), bool)
    term: LegWarmup = LegWarmupSearch(LEG).fix(r, offsets, rows, drivers)
    X = np.c_[offsets, term.columns(drivers)]
    coef, *_ = np.linalg.lstsq(X, r, rcond=None)
    dof = len(r) - X.shape[1]
    cov = np.linalg.inv(X.T @ X) * float(np.sum((r - X @ coef) ** 2) / dof)
    params, stderr, _ = term.describe(coef[6:], cov[6:, 6:])
    return params, stderr, slow


def test_a_warm_up_s_time_constant_and_size_are_found():
    for seed in range(3):
        params, stderr, slow = _found(seed)
        assert params["leg"] == LEG
        assert abs(params["settle_s"] - slow) <= 3 * stderr["settle_s"] + 20.0, (params, slow)
        # the reading comes out short by the growth: the settled change is negative
        size_bias = SETTLED_MM * 20.0 / 900.0
        off = abs(params["settled_mm"] + SETTLED_MM)
        assert off <= 3 * stderr["settled_mm"] + size_bias, (params, stderr)
