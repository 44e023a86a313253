"""The adaptive Monte Carlo procedure of JCGM 101:2008 (GUM Supplement 1) clause 7.9, for many
output quantities at once (a task's grid points), resumable batch by batch.

Trials come in batches of M (7.9.4 b: M = max(J, 10^4), J the least integer >= 100/(1 - p)). After
batch h each quantity has its batch results y^(r), u(y^(r)), y_low^(r), y_high^(r), r = 1 .. h
(the mean, standard deviation and coverage interval of that batch's M values, 7.6 and 7.7), and
each of these four has the standard deviation of its average over the h batches,

    s_z^2 = 1 / (h (h - 1)) * sum_r (z^(r) - mean_r z^(r))^2,    z in {y, u(y), y_low, y_high}.

The numerical tolerance delta of u(y) (7.9.2) is 1/2 10^l where u(y) = c 10^l, c an n_dig-digit
integer. The procedure stops when 2 s_z <= delta for all four and every quantity (7.9.4 k), or
when another batch would pass ``trials_max``. JCGM 101 8.2 asks results that validate the GUM
framework to be computed to delta/5: ``delta_scale=0.2``.

A batch's values are the caller's ``draw(index, M)``; seeded by the study's seed and the batch's
index alone (:func:`batch_rng`), a run given back its :class:`Batches` (``resume=``) draws exactly
the batches an uninterrupted run would have, so an interrupted study loses nothing.

The estimate y is the average of all h M values and u(y) their standard deviation, pooled exactly
from the batches' means and standard deviations (7.9.4 l). The endpoints are averages over the
batches too, so that no h M x Q values are kept: of the batches' endpoints for the
probabilistically symmetric interval (fixed order statistics: the very averages whose tolerance
the stop certifies, biased by O(1/M) of a spread); for the shortest interval, the shortest of the
averaged candidates [y_(r), y_(r+q)] (:func:`~.coverage.shortest_candidates`), as the pooled
values would give it, while the stop weighs the batches' own shortest intervals as 7.9.4 says
(their average is biased inward, by about 0.01 u(y) an endpoint at M = 10^4). Where the output
is symmetric the shortest interval's least width is flat, and its place wanders by more than the
tolerance long after its width and the probabilistically symmetric interval are settled: there
the symmetric interval (the default, and the same interval) is the one to state.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable

import numpy as np

from calibench.estimators.uncertainty.coverage import (
    coverage_interval,
    shortest_candidates,
    shortest_choice,
)

STATISTICS = ("y", "u", "low", "high")  # the order of the four batch results in every (4, ...)


def batch_size(p: float = 0.95) -> int:
    """M of JCGM 101 7.9.4 b): the trials of one batch.

    Parameters
    ----------
    p : float
        The coverage probability.

    Returns
    -------
    int
        max(J, 10^4), J the smallest integer >= 100 / (1 - p) (10^4 at p = 0.95).
    """
    # 100 / (1 - 0.95) is 2000.0000000000002 in floating point: J is 2000
    return max(int(np.ceil(100 / (1 - p) - 1e-9)), 10_000)


def numerical_tolerance(z, n_dig: int = 2) -> np.ndarray:
    """delta of JCGM 101 7.9.2: half a unit in the last of n_dig significant digits of z.

    z is written c x 10^l with c an n_dig-digit integer (z rounded to n_dig significant digits);
    delta = 1/2 x 10^l. u(y) = 2.00 with n_dig = 3 is 200 x 10^-2: delta = 0.005.

    Parameters
    ----------
    z : float or ndarray, shape (...)
        The value(s), e.g. u(y) of each output quantity.
    n_dig : int
        The significant digits regarded as meaningful.

    Returns
    -------
    ndarray, shape (...)
        delta of each value (0 where z is 0).
    """
    a = np.abs(np.asarray(z, float))
    nonzero = a > 0
    ell = np.floor(np.log10(np.where(nonzero, a, 1.0))) - n_dig + 1
    # 9.96 to two digits is 10 x 10^0, not 100 x 10^-1: rounding may carry into a new digit
    ell = np.where(np.round(a / 10.0**ell) >= 10.0**n_dig, ell + 1, ell)
    return np.where(nonzero, 0.5 * 10.0**ell, 0.0)


def batch_rng(seed: int, index: int) -> np.random.Generator:
    """The generator of batch ``index`` of a study seeded ``seed``.

    Its stream depends on the pair alone (numpy's SeedSequence of [seed, index]), so a resumed run
    draws the very batches an uninterrupted one would have.

    Parameters
    ----------
    seed : int
        The study's seed.
    index : int
        The batch's index, 0 for the first.

    Returns
    -------
    numpy.random.Generator
    """
    return np.random.default_rng([seed, index])


@dataclasses.dataclass(frozen=True)
class Batches:
    """Each batch's results, in batch order: what a resumed run is given back.

    ``y``, ``u``, ``low``, ``high`` are arrays of shape (h, Q): batch r's mean y^(r), standard
    deviation u(y^(r)) (1/(M - 1)) and coverage interval endpoints of each of the Q quantities.
    ``size`` is M, the trials of every batch; ``p`` and ``shortest`` the interval they hold;
    ``trace`` (h, 4) the run's :attr:`Adaptive.trace`. For the shortest interval ``orders``,
    shape (2, M - q, Q), holds the average over the batches of every candidate's endpoints
    (:func:`~.coverage.shortest_candidates`). Plain arrays and numbers: ``dataclasses.asdict``
    and ``numpy.savez`` keep them on disk.
    """

    y: np.ndarray
    u: np.ndarray
    low: np.ndarray
    high: np.ndarray
    size: int
    p: float = 0.95
    shortest: bool = False
    trace: np.ndarray | None = None
    orders: np.ndarray | None = None

    @property
    def count(self) -> int:
        """h, the number of batches."""
        return len(self.y)

    @property
    def trials(self) -> int:
        """h M, the trials of all batches."""
        return self.count * self.size

    def rows(self) -> np.ndarray:
        """The four results stacked, shape (h, 4, Q), in :data:`STATISTICS` order."""
        return np.stack([self.y, self.u, self.low, self.high], axis=1)


@dataclasses.dataclass(frozen=True)
class Adaptive:
    """The adaptive procedure's result for Q output quantities.

    ``y``, ``u``, ``low``, ``high`` (Q,): the estimate, its standard uncertainty and the coverage
    interval's endpoints; ``trials`` h M; ``batches`` each batch's results (give them back to
    resume); ``delta`` (Q,) the numerical tolerance of each u(y) at ``n_dig`` digits, and the stop
    was twice each standard deviation <= ``delta_scale`` x delta; ``deviations`` (4, Q) the
    standard deviations s of the four averages after the last batch; ``converged`` and ``status``
    why it stopped; ``trace`` (h, 4): after each batch, the largest 2 s / (delta_scale delta) over
    the quantities of each of the four results (NaN after the first batch, which has no s).
    """

    y: np.ndarray
    u: np.ndarray
    low: np.ndarray
    high: np.ndarray
    trials: int
    batches: Batches
    delta: np.ndarray
    delta_scale: float
    deviations: np.ndarray
    converged: bool
    status: str
    trace: np.ndarray


def batch_results(values: np.ndarray, p: float = 0.95, shortest: bool = False) -> np.ndarray:
    """One batch's results of each quantity: its mean, standard deviation and coverage interval.

    Parameters
    ----------
    values : ndarray, shape (M, Q)
        The batch's M model values of each of Q quantities.
    p, shortest : the coverage probability and whether the interval is the shortest (7.7.2)
        rather than the probabilistically symmetric one (7.7.1).

    Returns
    -------
    ndarray, shape (4, Q)
        y^(r), u(y^(r)) (ddof 1), y_low^(r), y_high^(r), in :data:`STATISTICS` order.
    """
    low, high = coverage_interval(values, p, shortest)
    return np.stack([values.mean(axis=0), values.std(axis=0, ddof=1), low, high])


class _Welford:
    """Running mean and sum of squared deviations of equally shaped arrays, one per batch."""

    def __init__(self) -> None:
        self.mean: np.ndarray | None = None
        self.m2: np.ndarray | None = None
        self.h = 0

    def add(self, x: np.ndarray) -> None:
        if self.mean is None or self.m2 is None:
            self.mean, self.m2 = np.zeros_like(x), np.zeros_like(x)
        self.h += 1
        d = x - self.mean
        self.mean = self.mean + d / self.h
        self.m2 = self.m2 + d * (x - self.mean)


class _Averages:
    """The averages over the batches so far and the s of each: O(Q) a batch (O((M - q) Q) for the
    shortest interval) however many came before."""

    def __init__(self, m: int, shortest: bool) -> None:
        self.m, self.shortest = m, shortest
        self.rows = _Welford()
        self.orders: np.ndarray | None = None  # the candidates' running average, (2, M - q, Q)
        self.u2_sum: np.ndarray = np.zeros(0)

    @property
    def h(self) -> int:
        return self.rows.h

    def add(self, row: np.ndarray, orders: np.ndarray | None) -> None:
        self.u2_sum = self.u2_sum + row[1] ** 2 if self.h else row[1] ** 2
        self.rows.add(row)
        if orders is not None:
            prev = self.orders if self.orders is not None else np.zeros_like(orders)
            self.orders = prev + (orders - prev) / self.h

    def u(self) -> np.ndarray:
        """The standard deviation of all h M values (Q,): within- plus between-batch sums."""
        assert self.rows.m2 is not None
        ss = (self.m - 1) * self.u2_sum + self.m * self.rows.m2[0]
        return np.sqrt(ss / (self.h * self.m - 1))

    def summary(self) -> tuple[np.ndarray, np.ndarray]:
        """The averages (4, Q) (y, u(y) of the batches, the endpoints) and their s (4, Q)."""
        mean, m2 = self.rows.mean, self.rows.m2
        assert mean is not None and m2 is not None
        mean, m2 = mean.copy(), m2.copy()
        if self.shortest:
            assert self.orders is not None
            # the s stay those of the batches' own shortest intervals (7.9.4 as written): their
            # scatter holds the wander of the shortest along a flat least width, the averaged
            # candidates' at one r would not
            mean[2], mean[3], _ = shortest_choice(self.orders)
        s = np.sqrt(m2 / ((self.h - 1) * self.h)) if self.h > 1 else np.full(m2.shape, np.inf)
        return mean, s


def _ratio(two_s: np.ndarray, tol: np.ndarray) -> np.ndarray:
    """2 s / tolerance, 0 for 0/0 (a constant quantity) and inf for s > 0 at a zero tolerance."""
    safe = np.where(tol > 0, tol, 1.0)
    return np.where(tol > 0, two_s / safe, np.where(two_s > 0, np.inf, 0.0))


def _batch(draw, index: int, m: int, q: int | None, p: float, shortest: bool):
    """Batch ``index``: its (4, Q) results and, for the shortest interval, its candidates."""
    v = np.asarray(draw(index, m), float)
    v = v[:, None] if v.ndim == 1 else v
    if v.ndim != 2 or v.shape[0] != m or (q is not None and v.shape[1] != q):
        want = f"({m}, {q if q is not None else 'Q'})"
        raise ValueError(f"draw({index}, {m}) gave shape {v.shape}, not {want}")
    if not shortest:
        return batch_results(v, p), None
    cand = shortest_candidates(v, p)
    low, high, _ = shortest_choice(cand)
    return np.stack([v.mean(axis=0), v.std(axis=0, ddof=1), low, high]), cand


def _resumed(resume: Batches, m: int, p: float, shortest: bool) -> _Averages:
    if (resume.size, resume.p, resume.shortest) != (m, p, shortest):
        raise ValueError(
            f"resumed batches are of M={resume.size}, p={resume.p}, shortest={resume.shortest}; "
            f"this run's of M={m}, p={p}, shortest={shortest}"
        )
    averages = _Averages(m, shortest)
    for row in resume.rows():
        averages.add(row, None)
    if shortest:
        if resume.orders is None:
            raise ValueError("resumed shortest-interval batches carry no candidates (orders)")
        averages.orders = np.array(resume.orders, float)
    return averages


def _resumed_trace(resume: Batches) -> np.ndarray:
    """The resumed run's trace, NaN rows where batches came without one."""
    if resume.trace is not None and len(resume.trace) == resume.count:
        return np.asarray(resume.trace, float)
    return np.full((resume.count, 4), np.nan)


def adaptive(
    draw: Callable[[int, int], np.ndarray],
    p: float = 0.95,
    n_dig: int = 2,
    size: int | None = None,
    trials_max: int = 10**7,
    shortest: bool = False,
    delta_scale: float = 1.0,
    resume: Batches | None = None,
    tolerance: float | None = None,
) -> Adaptive:
    """The adaptive Monte Carlo procedure of JCGM 101 7.9.4 over Q output quantities.

    Batches r = 0, 1, ... of M trials each, ``draw(r, M) -> (M, Q)``, until 2 s_z <= delta_scale
    x delta for z in (y, u(y), y_low, y_high) at every quantity (delta of u(y) at ``n_dig``
    digits, 7.9.2), or until another batch would pass ``trials_max``.

    Parameters
    ----------
    draw : callable (index, M) -> ndarray, shape (M, Q) (or (M,) for one quantity)
        Batch ``index``'s M model values; for a resumable study, a function of the seed and the
        index only (:func:`batch_rng`).
    p : float
        The coverage probability.
    n_dig : int
        The significant digits of u(y) regarded as meaningful (7.9.2).
    size : int, optional
        M (default :func:`batch_size` of p, or the resumed batches' M).
    trials_max : int
        The most trials; at least two batches' worth.
    shortest : bool
        The shortest coverage interval (7.7.2) instead of the probabilistically symmetric one.
    delta_scale : float
        The stop's tolerance as a fraction of delta (0.2 for results that validate the GUM
        framework, JCGM 101 8.2).
    resume : Batches, optional
        Batches of an earlier run with the same M, p and interval: all are kept, and drawing
        goes on from batch ``resume.count`` while the tolerance is not met.
    tolerance : float, optional
        delta stated outright, in the quantities' unit, for every quantity (7.9.1 lets the user
        state it), instead of n_dig digits of each u(y).

    Returns
    -------
    Adaptive

    Raises
    ------
    ValueError
        On a ``draw`` of the wrong shape, resumed batches of another M, p or interval, or a
        ``trials_max`` below two batches.
    """
    m = size if size is not None else (resume.size if resume is not None else batch_size(p))
    if trials_max < 2 * m:
        raise ValueError(f"trials_max {trials_max} holds fewer than two batches of {m}")
    averages = _resumed(resume, m, p, shortest) if resume is not None else _Averages(m, shortest)
    rows = list(resume.rows()) if resume is not None else []
    trace = [] if resume is None else list(_resumed_trace(resume))
    met = averages.h > 1 and _met(averages, n_dig, delta_scale, tolerance)[0]
    while not met and (averages.h + 1) * m <= trials_max:
        q = rows[0].shape[1] if rows else None
        row, cand = _batch(draw, averages.h, m, q, p, shortest)
        rows.append(row)
        averages.add(row, cand)
        if averages.h < 2:
            trace.append(np.full(4, np.nan))
            continue
        met, worst = _met(averages, n_dig, delta_scale, tolerance)
        trace.append(worst)
    return _result(rows, averages, p, delta_scale, n_dig, np.array(trace), tolerance)


def _delta(u: np.ndarray, n_dig: int, tolerance: float | None) -> np.ndarray:
    """Each quantity's delta: ``tolerance`` where stated, else n_dig digits of its u(y)."""
    if tolerance is None:
        return numerical_tolerance(u, n_dig)
    return np.full(np.shape(u), float(tolerance))


def _met(
    averages: _Averages, n_dig: int, delta_scale: float, tolerance: float | None = None
) -> tuple[bool, np.ndarray]:
    """Whether 2 s <= delta_scale delta everywhere (7.9.4 k), and the largest ratio of each of
    the four results (4,)."""
    _, s = averages.summary()
    ratio = _ratio(2 * s, delta_scale * _delta(averages.u(), n_dig, tolerance)[None, :])
    return bool(np.all(ratio <= 1)), ratio.max(axis=1)


def _result(
    rows, averages: _Averages, p, delta_scale, n_dig, trace, tolerance: float | None = None
) -> Adaptive:
    """The :class:`Adaptive` of the batches run."""
    stacked = np.stack(rows)  # (h, 4, Q)
    h, q, m = averages.h, stacked.shape[2], averages.m
    batches = Batches(
        y=stacked[:, 0],
        u=stacked[:, 1],
        low=stacked[:, 2],
        high=stacked[:, 3],
        size=m,
        p=p,
        shortest=averages.shortest,
        trace=trace,
        orders=averages.orders,
    )
    mean, s = averages.summary()
    u = averages.u()
    delta = _delta(u, n_dig, tolerance)
    ratio = _ratio(2 * s, delta_scale * delta[None, :])
    converged = bool(np.all(ratio <= 1))
    if converged:
        status = f"tolerance met after {h} batches"
    else:
        short = int(np.sum(np.any(ratio > 1, axis=0)))
        status = (
            f"trials_max reached after {h} batches: tolerance not met at {short} of {q} quantities"
        )
    return Adaptive(
        y=mean[0],
        u=u,
        low=mean[2],
        high=mean[3],
        trials=h * m,
        batches=batches,
        delta=delta,
        delta_scale=delta_scale,
        deviations=s,
        converged=converged,
        status=status,
        trace=trace,
    )
