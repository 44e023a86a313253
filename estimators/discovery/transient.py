"""An error that appears at each reversal of an axis and dies away with the travel since: the
pre-sliding of a friction contact, a settling carriage (the contract's ``reversal_transient``).

    e = A dir exp(-s / decay)

with ``dir`` the axis's direction of last motion (+1 / -1) and ``s`` the distance travelled since
its last reversal (:mod:`calibench.estimators.discovery.motion`, over the rows in time order, each
pass its own history). The decay length is searched on the rows the term is fitted to
(:meth:`TransientSearch.fix`); a constant lost motion is the limit of a long decay
(``backlash``), so the search stops at a quarter of the travel.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from calibench.estimators.discovery.effect import Drivers, Effect, coef_std
from calibench.estimators.discovery.motion import last_direction, since_reversal
from calibench.estimators.discovery.search import profile, within_one_sigma

DECAY_GRID = 30  # decay lengths tried, log-spaced
SHORTEST_DECAY_MM = 0.2
LONGEST_DECAY = 1 / 20  # of the travel: beyond it a transient is lost motion that grows
LONGEST_DECAY_MM = 10.0  # and at most this: stick-slip and settling die within millimetres
# rows within one decay length of a reversal that resolve a transient: with fewer, its amplitude
# is extrapolated from rows where it has died away (a 1e43 mm transient fitted one far row)
RESOLVED_ROWS = 3


def reversal_drivers(u: np.ndarray, t_s, series) -> tuple[np.ndarray, np.ndarray]:
    """The direction of last motion and the travel since the last reversal (n,) of positions
    ``u`` (n,), over the rows in time order (``t_s``, or as given), ``series`` (n,) restarting
    the history (a pass)."""
    u = np.asarray(u, float)
    n = len(u)
    order = np.arange(n) if t_s is None else np.argsort(np.asarray(t_s, float), kind="stable")
    if series is not None:
        order = order[np.argsort(np.asarray(series)[order], kind="stable")]
    s = None if series is None else np.asarray(series)[order]
    direction, since = np.empty(n), np.empty(n)
    direction[order] = last_direction(u[order], s)
    since[order] = since_reversal(u[order], s)
    return direction, since


@dataclasses.dataclass(frozen=True)
class ReversalTransient(Effect):
    """A of ``axis``'s reading after each reversal, decaying over ``decay_mm`` (std
    ``decay_std_mm``) of travel."""

    name: str = "reversal_transient"
    decay_mm: float = 1.0
    decay_std_mm: float = 0.0
    # the search's best decay was its longest: no transient, lost motion that grows or stays
    at_bound: bool = False
    local = True  # acts near reversals only: judged on those rows (select's gain_where_it_acts)

    def __post_init__(self):
        object.__setattr__(self, "needs", (self.axis,))

    def columns(self, d: Drivers) -> np.ndarray:
        return _column(d, self.axis, self.decay_mm)[:, None]

    def describe(self, coef, cov):
        a = float(coef[0])
        return (
            {"amplitude_mm": a, "decay_mm": self.decay_mm},
            {"amplitude_mm": coef_std(cov, 0), "decay_mm": self.decay_std_mm},
            f"after each reversal the {self.axis.upper()} reading is {a * 1000:+.2f} um off in the "
            f"new direction, dying away over {self.decay_mm:.2f} mm of travel (+- "
            f"{self.decay_std_mm:.2f} mm): pre-sliding friction or settling, not a constant "
            "lost motion",
        )


def _grid(u) -> np.ndarray:
    """The decay lengths searched (K,) over an axis's positions ``u`` (n,)."""
    longest = min(float(np.ptp(np.asarray(u, float))) * LONGEST_DECAY, LONGEST_DECAY_MM)
    return np.geomspace(SHORTEST_DECAY_MM, longest, DECAY_GRID)


def _resolved(grid: np.ndarray, since: np.ndarray) -> np.ndarray:
    """Which decay lengths (K,) have :data:`RESOLVED_ROWS` rows within them of a reversal."""
    return np.count_nonzero(since[:, None] <= grid[None, :], axis=0) >= RESOLVED_ROWS


def _column(d: Drivers, axis: str, decay_mm: float) -> np.ndarray:
    direction, since = reversal_drivers(d[axis], d.get("t_s"), d.get("run"))
    return direction * np.exp(-since / decay_mm)


@dataclasses.dataclass(frozen=True)
class TransientSearch:
    """A reversal transient whose decay length is found on the rows it is fitted to."""

    axis: str
    name: str = "reversal_transient"
    local = True  # as the transient it fixes

    @property
    def key(self) -> str:
        """As the term it fixes."""
        return f"{self.name}:{self.axis}"

    def applies(self, drivers: Drivers) -> bool:
        """An axis that reverses, with a travel to decay over."""
        u = drivers.get(self.axis)
        if u is None or np.ptp(np.asarray(u, float)) * LONGEST_DECAY <= 2 * SHORTEST_DECAY_MM:
            return False
        direction, since = reversal_drivers(u, drivers.get("t_s"), drivers.get("run"))
        reverses = bool(np.any(direction > 0) and np.any(direction < 0))
        return reverses and bool(np.any(_resolved(_grid(u), since)))

    def fix(
        self, r: np.ndarray, others: np.ndarray, rows: np.ndarray, drivers: Drivers
    ) -> ReversalTransient:
        """The decay length whose transient cuts ``r`` (m,) most beside ``others`` on ``rows``."""
        grid = _grid(drivers[self.axis])
        direction, since = reversal_drivers(
            drivers[self.axis], drivers.get("t_s"), drivers.get("run")
        )
        grid = grid[_resolved(grid, since)]
        C = direction[:, None] * np.exp(-since[:, None] / grid[None, :])
        best, rss, sigma2 = profile(r[rows], others[rows], C[rows])
        step = grid[min(best + 1, len(grid) - 1)] - grid[max(best - 1, 0)]
        std = max(within_one_sigma(grid, rss, best, sigma2), step / 2 / np.sqrt(3))
        return ReversalTransient(
            axis=self.axis,
            decay_mm=float(grid[best]),
            decay_std_mm=std,
            at_bound=best == len(grid) - 1,
        )
