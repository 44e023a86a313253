"""A reading that settles after power-on: a warm-up whose time constant is searched.

A part warming from the moment the machine was switched on (a leg's motor and tube, a read head)
moves a reading by a size ``D`` that it reaches through a first-order lag of the switch-on, time
constant ``settle_s``:

    e(t) = D (1 - exp(-(t - t_0) / settle_s))

``t_0`` the recording's first time. No temperature of that part is logged: the lag is of a step
at the start, not of the air. ``thermal_drift``'s slope and bend in time write a steady warming;
this writes one that has settled within the recording. Offered for a Stewart platform's legs
(rows stacked pose by pose, six a pose, as :mod:`.stewart` stacks them).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from calibench.estimators.discovery.effect import Drivers, coef_std
from calibench.estimators.discovery.search import profile, within_one_sigma
from calibench.estimators.discovery.stewart import LegEffect, on_leg

SETTLE_GRID = 40  # time constants tried, log-spaced
SHORTEST_SETTLE_S = 60.0
# longer than half the recording a settling is a bend in time: thermal_drift's own
LONGEST_SHARE = 0.5


def _settling(d: Drivers, settle_s: float) -> np.ndarray:
    """The settling's shape (n,) at the poses' times: from 0 at the start to 1, less its mean."""
    t = np.asarray(d["t_s"], float)
    s = 1.0 - np.exp(-(t - t.min()) / settle_s)
    return s - s.mean()


@dataclasses.dataclass(frozen=True)
class LegWarmup(LegEffect):
    """Leg ``leg``'s reading settles by ``D`` mm with time constant ``settle_s`` (its std
    ``settle_std_s``) from the recording's start."""

    name: str = "thermal_drift"
    settle_s: float = 0.0
    settle_std_s: float = 0.0

    def __post_init__(self):
        object.__setattr__(self, "needs", ("t_s",))

    @property
    def key(self) -> str:
        """Beside the leg's drift in time: a second shape of the same name."""
        return f"{self.name}:leg{self.leg}:settling"

    def columns(self, d):
        return on_leg(_settling(d, self.settle_s), self.leg)

    def describe(self, coef, cov):
        D = float(coef[0])
        return (
            {"leg": self.leg, "settled_mm": D, "settle_s": self.settle_s},
            {"settled_mm": coef_std(cov, 0), "settle_s": self.settle_std_s},
            f"leg {self.leg}'s reading settles by {D * 1000:+.2f} um from the recording's start, "
            f"time constant {self.settle_s / 60:.0f} min (+- {self.settle_std_s / 60:.0f}): a "
            "part warming up since the machine was switched on (a motor and its leg, a read head)",
        )


@dataclasses.dataclass(frozen=True)
class LegWarmupSearch:
    """A leg's warm-up whose time constant is found on the rows it is fitted to."""

    leg: int
    axis: str = "legs"
    name: str = "thermal_drift"

    @property
    def key(self) -> str:
        """As the term it fixes."""
        return LegWarmup(leg=self.leg).key

    def applies(self, drivers: Drivers) -> bool:
        """Times that span more than the shortest settling twice over."""
        t = drivers.get("t_s")
        return t is not None and np.ptp(np.asarray(t, float)) > 2 * SHORTEST_SETTLE_S

    def fix(
        self, r: np.ndarray, others: np.ndarray, rows: np.ndarray, drivers: Drivers
    ) -> LegWarmup:
        """The time constant whose settling cuts ``r`` (6 n,) most beside ``others`` on
        ``rows``."""
        t = np.asarray(drivers["t_s"], float)
        grid = np.geomspace(SHORTEST_SETTLE_S, LONGEST_SHARE * np.ptp(t), SETTLE_GRID)
        C = np.stack([on_leg(_settling(drivers, tau), self.leg)[:, 0] for tau in grid], axis=1)
        best, rss, sigma2 = profile(r[rows], others[rows], C[rows])
        step = grid[min(best + 1, len(grid) - 1)] - grid[max(best - 1, 0)]
        std = max(within_one_sigma(grid, rss, best, sigma2), step / 2 / np.sqrt(3))
        return LegWarmup(leg=self.leg, settle_s=float(grid[best]), settle_std_s=std)
