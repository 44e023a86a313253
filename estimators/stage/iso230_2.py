"""Positioning accuracy and repeatability of a numerically controlled axis, ISO 230-2:2014.

Evaluates the figures of ISO 230-2:2014 (Test code for machine tools -- Part 2: Determination
of accuracy and repeatability of positioning of numerically controlled axes) from m target
positions P_i and n runs per approach direction. A positioning deviation is the actual position
minus the target position, x_ij = P_ij - P_i; "up" is the approach in the positive direction,
"down" in the negative one. Every figure is in the unit of the deviations.
"""

from __future__ import annotations

import dataclasses

import numpy as np

AXIS_FIGURES = (
    "B",
    "B_mean",
    "R_up",
    "R_down",
    "R",
    "E_up",
    "E_down",
    "E",
    "M",
    "A_up",
    "A_down",
    "A",
)


@dataclasses.dataclass(frozen=True)
class Iso2302Result:
    """ISO 230-2 figures of one axis.

    Per target, each (m,): mean_up, mean_down (x̄_i↑, x̄_i↓), mean_bi (x̄_i), reversal_i (B_i),
    s_up, s_down (s_i↑, s_i↓), R_up_i, R_down_i (R_i↑, R_i↓), R_i.
    Axis figures, floats: B, B_mean, R_up, R_down, R, E_up, E_down, E, M, A_up, A_down, A.
    """

    mean_up: np.ndarray
    mean_down: np.ndarray
    mean_bi: np.ndarray
    reversal_i: np.ndarray
    s_up: np.ndarray
    s_down: np.ndarray
    R_up_i: np.ndarray
    R_down_i: np.ndarray
    R_i: np.ndarray
    B: float
    B_mean: float
    R_up: float
    R_down: float
    R: float
    E_up: float
    E_down: float
    E: float
    M: float
    A_up: float
    A_down: float
    A: float

    def as_dict(self) -> dict:
        """The axis figures only, as plain floats keyed by field name."""
        return {name: float(getattr(self, name)) for name in AXIS_FIGURES}


def _check_inputs(targets, dev_up, dev_down) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Validate and convert to float arrays (m,), (m, n), (m, n); raise ValueError otherwise."""
    P = np.asarray(targets, dtype=float)
    up = np.asarray(dev_up, dtype=float)
    down = np.asarray(dev_down, dtype=float)
    if P.ndim != 1 or up.ndim != 2 or up.shape != down.shape or up.shape[0] != P.shape[0]:
        raise ValueError(
            f"shape mismatch: targets {P.shape}, dev_up {up.shape} and dev_down {down.shape} "
            "must be (m,), (m, n) and (m, n)"
        )
    m, n = up.shape
    if m < 2:
        raise ValueError(f"{m} target position(s): the axis figures need at least 2")
    if n < 2:
        raise ValueError(f"{n} run(s) per direction: the standard uncertainty s needs at least 2")
    if not (np.isfinite(P).all() and np.isfinite(up).all() and np.isfinite(down).all()):
        raise ValueError("targets and deviations must all be finite (no NaN or inf)")
    return P, up, down


def _span(upper: np.ndarray, lower: np.ndarray) -> float:
    """max(upper) - min(lower) over every element, arrays of any shape."""
    return float(np.max(upper) - np.min(lower))


def evaluate(targets, dev_up, dev_down) -> Iso2302Result:
    """Evaluate an axis as ISO 230-2:2014.

    Parameters
    ----------
    targets : array_like, (m,)
        Target positions P_i. They enter only the validation: no figure depends on them.
    dev_up, dev_down : array_like, (m, n)
        Positioning deviations x_ij↑ and x_ij↓ (actual minus target), row i for target i,
        column j for run j, approaching in the positive and negative direction.

    Returns
    -------
    Iso2302Result
        Per-target arrays (m,) and the axis figures, in the unit of the deviations.

    Raises
    ------
    ValueError
        On mismatched shapes, fewer than 2 targets, fewer than 2 runs, or a non-finite value.
    """
    _, up, down = _check_inputs(targets, dev_up, dev_down)
    mean_up, mean_down = up.mean(axis=1), down.mean(axis=1)
    # ddof=1: the standard's estimator divides by n - 1
    s_up, s_down = up.std(axis=1, ddof=1), down.std(axis=1, ddof=1)
    mean_bi = (mean_up + mean_down) / 2
    reversal_i = mean_up - mean_down
    R_up_i, R_down_i = 4 * s_up, 4 * s_down
    # 2s↑ + 2s↓ + |B_i| falls below one direction's 4 s when that direction scatters far more
    # than the other and |B_i| is small
    R_i = np.max([2 * s_up + 2 * s_down + np.abs(reversal_i), R_up_i, R_down_i], axis=0)
    # both directions stacked, (2, m), for the bidirectional E and A
    means = np.stack([mean_up, mean_down])
    two_s = 2 * np.stack([s_up, s_down])
    return Iso2302Result(
        mean_up=mean_up,
        mean_down=mean_down,
        mean_bi=mean_bi,
        reversal_i=reversal_i,
        s_up=s_up,
        s_down=s_down,
        R_up_i=R_up_i,
        R_down_i=R_down_i,
        R_i=R_i,
        B=float(np.max(np.abs(reversal_i))),
        B_mean=float(np.mean(reversal_i)),
        R_up=float(np.max(R_up_i)),
        R_down=float(np.max(R_down_i)),
        R=float(np.max(R_i)),
        E_up=_span(mean_up, mean_up),
        E_down=_span(mean_down, mean_down),
        E=_span(means, means),
        M=_span(mean_bi, mean_bi),
        A_up=_span(mean_up + 2 * s_up, mean_up - 2 * s_up),
        A_down=_span(mean_down + 2 * s_down, mean_down - 2 * s_down),
        A=_span(means + two_s, means - two_s),
    )
