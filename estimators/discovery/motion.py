"""Drivers derived from a recording's logged columns, for every instrument: the direction of an
axis's (or joint's) last motion, the distance it travelled since its last reversal, and a logged
temperature seen through a first-order lag.

Rows are taken in the order given (a recording's time order); ``series`` (n,) ids restart the
history where a new pass or recording begins.
"""

from __future__ import annotations

import numpy as np


def _starts(series: np.ndarray | None, n: int) -> np.ndarray:
    """(n,) bool: where a new series begins (the first row always)."""
    start = np.zeros(n, bool)
    start[:1] = True
    if series is not None:
        s = np.asarray(series)
        start[1:] |= s[1:] != s[:-1]
    return start


def last_direction(u: np.ndarray, series: np.ndarray | None = None) -> np.ndarray:
    """The sign (+1 / -1) of the last change of ``u`` (n,) before each row, 0 until the first
    move of its series: the direction a drive last turned in, whatever the steps' size."""
    u = np.asarray(u, float)
    n = len(u)
    start = _starts(series, n)
    step = np.r_[0.0, np.diff(u)]
    step[start] = 0.0
    sign = np.sign(step)
    rows = np.arange(n)
    last = np.maximum.accumulate(np.where(sign != 0, rows, -1))  # the last move up to each row
    first = np.maximum.accumulate(np.where(start, rows, 0))  # where each row's series began
    return np.where(last >= first, sign[np.maximum(last, 0)], 0.0)


def since_reversal(u: np.ndarray, series: np.ndarray | None = None) -> np.ndarray:
    """The distance (|u| units) travelled since the last reversal of ``u``'s direction, (n,): what
    an error that appears at a reversal and dies away with travel (stick-slip, settling) follows.
    Before a series' first reversal, the distance since its start."""
    u = np.asarray(u, float)
    n = len(u)
    start = _starts(series, n)
    d = last_direction(u, series)
    reversed_here = start | (np.r_[0.0, d[:-1]] * d < 0)
    anchor = np.maximum.accumulate(np.where(reversed_here, np.arange(n), 0))
    # at a reversal the travel restarts from the row before it, where the drive turned
    turn = np.where(start[anchor], anchor, anchor - 1)
    return np.abs(u - u[turn])


def lagged(temp_c: np.ndarray, t_s: np.ndarray, tau_s: float) -> np.ndarray:
    """The temperature a part with time constant ``tau_s`` reaches following ``temp_c`` (n,)
    logged at ``t_s`` (n,, increasing): T' = (T_air - T) / tau, exact for an air temperature
    linear between samples; it starts at the first reading.

    Between samples k - 1 and k (a = exp(-dt / tau), s the air's slope) the recursion is
    y_k = a y_{k-1} + b_k, b_k = T_k - s tau - a (T_{k-1} - s tau), solved in closed form,
    y_k = A_k (y_0 + sum_j b_j / A_j) with A_k the product of the a's, in stretches short enough
    that 1 / A stays finite.
    """
    T = np.asarray(temp_c, float)
    t = np.asarray(t_s, float)
    out = np.empty_like(T)
    out[0] = T[0]
    if len(T) < 2:
        return out
    dt = np.diff(t)
    log_a = -dt / tau_s
    a = np.exp(log_a)
    slope = np.diff(T) / np.where(dt > 0, dt, 1.0)
    b = T[1:] - slope * tau_s - a * (T[:-1] - slope * tau_s)
    decay = np.cumsum(log_a)  # log A_k, k = 1 .. n - 1
    start, y = 0, T[0]
    while start < len(b):
        # a stretch over which A falls by at most e^-600 (1 / A finite)
        base = decay[start - 1] if start else 0.0
        end = max(int(np.searchsorted(-(decay - base), 600.0, side="right")), start + 1)
        L = decay[start:end] - base
        out[start + 1 : end + 1] = np.exp(L) * (y + np.cumsum(b[start:end] * np.exp(-L)))
        start, y = end, out[end]
    return out
