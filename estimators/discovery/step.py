"""A reading that changes suddenly at one moment: a knock, a slipped encoder, a re-homing.

On an axis's reading (mm) or on an arm joint's angle (rad, through d(point) / d(q)):

    e(t) = s H(t - at_s)          (axis)
    dp(t) = -J_q(t) s H(t - at_s) (joint j: the reading is off by s after the moment)

The moment is searched on the rows the step is fitted to (:meth:`StepSearch.fix`): every moment
between two successive distinct times with at least :data:`MIN_SIDE` samples on each side, the
one that cuts the residual most beside the other columns. Its uncertainty is the profile's: the
moments whose residual sum of squares is within one noise variance of the best.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from calibench.estimators.discovery.effect import Drivers, Effect, coef_std
from calibench.estimators.discovery.search import profile, within_one_sigma

MIN_SIDE = 10  # samples on each side of a moment searched: a step at an end is an offset
MAX_MOMENTS = 400  # moments tried at most (quantiles of the times beyond it)


@dataclasses.dataclass(frozen=True)
class Step(Effect):
    """A step of ``size`` at ``at_s`` (its std ``at_std_s``) on an axis's reading or, with
    ``joint`` > 0, on that joint's angle."""

    name: str = "step"
    joint: int = 0
    at_s: float = 0.0
    at_std_s: float = 0.0

    def __post_init__(self):
        object.__setattr__(self, "needs", ("t_s", "Jq") if self.joint else ("t_s",))

    @property
    def key(self) -> str:
        """The step's name and what it acts on: an axis, or a joint."""
        return f"{self.name}:{f'joint{self.joint}' if self.joint else self.axis}"

    def columns(self, d: Drivers) -> np.ndarray:
        h = (np.asarray(d["t_s"], float) >= self.at_s).astype(float)
        return _shape(d, self.joint, h[:, None])

    def describe(self, coef, cov):
        s = float(coef[0])
        unit, scale, said = ("urad", 1e6, "urad") if self.joint else ("mm", 1.0, "mm")
        what = f"joint {self.joint}'s reading" if self.joint else f"the {self.axis.upper()} reading"
        size = {f"size_{unit}": s * scale}
        params = {**({"joint": self.joint} if self.joint else {}), **size, "at_s": self.at_s}
        stderr = {f"size_{unit}": coef_std(cov, 0) * scale, "at_s": self.at_std_s}
        shown = s * scale if self.joint else s * 1000
        return (
            params,
            stderr,
            f"{what} changes by {shown:+.1f} {said if self.joint else 'um'} at "
            f"{self.at_s:.0f} s (+- {self.at_std_s:.0f} s) and stays: a knock, a slipped "
            "encoder or a re-homing, not a drift",
        )


def _shape(d: Drivers, joint: int, H: np.ndarray) -> np.ndarray:
    """Columns (m, k) of step indicators ``H`` (n, k) on the signal's rows: as they are on an
    axis; through joint ``joint``'s d(point) / d(q) (n, 3) for an arm, the point's three
    coordinates row by row (the true angle is the reading minus the error)."""
    if not joint:
        return H
    Jt = np.asarray(d["Jq"], float)[:, :, joint - 1]
    return -(Jt[:, :, None] * H[:, None, :]).reshape(3 * len(H), H.shape[1])


@dataclasses.dataclass(frozen=True)
class StepSearch:
    """A step whose moment is found on the rows it is fitted to."""

    axis: str
    joint: int = 0
    name: str = "step"

    @property
    def key(self) -> str:
        """As the step it fixes."""
        return Step(axis=self.axis, joint=self.joint).key

    def applies(self, drivers: Drivers) -> bool:
        """A logged time with room for a moment between enough samples."""
        t = drivers.get("t_s")
        need = ("Jq",) if self.joint else ()
        return (
            t is not None
            and len(np.unique(np.asarray(t, float))) > 2 * MIN_SIDE
            and all(drivers.get(k) is not None for k in need)
        )

    def fix(self, r: np.ndarray, others: np.ndarray, rows: np.ndarray, drivers: Drivers) -> Step:
        """The moment that cuts ``r`` (m,) most beside ``others`` (m, p) on ``rows`` (m,) bool."""
        t = np.asarray(drivers["t_s"], float)
        sample_rows = rows.reshape(len(t), -1).any(axis=1)
        times = np.unique(t[sample_rows])
        cuts = (times[MIN_SIDE - 1 : -MIN_SIDE] + times[MIN_SIDE : -MIN_SIDE + 1]) / 2
        if len(cuts) > MAX_MOMENTS:
            cuts = np.quantile(cuts, np.linspace(0, 1, MAX_MOMENTS))
        H = (t[:, None] >= cuts[None, :]).astype(float)
        C = _shape(drivers, self.joint, H)[rows]
        best, rss, sigma2 = profile(r[rows], others[rows], C)
        # the moment lies anywhere between the samples either side of the cut (uniform: the
        # interval over sqrt 12), or as wide as the profile says
        k = int(np.searchsorted(times, cuts[best]))
        gap = times[min(k, len(times) - 1)] - times[max(k - 1, 0)]
        std = max(within_one_sigma(cuts, rss, best, sigma2), gap / np.sqrt(12))
        return Step(axis=self.axis, joint=self.joint, at_s=float(cuts[best]), at_std_s=float(std))
