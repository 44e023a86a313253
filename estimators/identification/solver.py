"""Levenberg-Marquardt over a problem's kept parameters, with its status, trace and covariance.

The one solver of calibench's identifications (the arm's problems, the Stewart platform's joint
adjustment): it takes a :class:`~calibench.estimators.identification.problem.Problem` and a
:class:`~calibench.estimators.identification.basis.Basis`, and returns the estimate, its
covariance, why it stopped (:class:`Status`) and what each iteration did (:class:`Iteration`),
after mujoco's ``minimize.least_squares``. A problem whose Jacobian is a scipy.sparse matrix
(many nuisance blocks: the Stewart platform's poses) has its normal equations and covariance
factorised sparsely (:mod:`calibench.estimators.identification.normal`); a dense one's
arithmetic is that of a plain LAPACK solve.
"""

from __future__ import annotations

import dataclasses
import enum

import numpy as np
from scipy import sparse

from calibench.estimators.identification.basis import Basis, identifiable_basis
from calibench.estimators.identification.covariance import covariance
from calibench.estimators.identification.normal import NormalEquations, normal_equations
from calibench.estimators.identification.problem import Problem, State

# a sum of squares of a few hundred whitened residuals is exact to about 1e-14 of itself: a
# promised decrease below this fraction of the cost is rounding (a step of ~1e-6 std)
COST_ROUNDING = 1e-13


class Status(enum.Enum):
    """Why the solver stopped; the first three are a minimum."""

    COST_ROUNDING = "even the undamped step would lower the cost by less than its rounding"
    SMALL_STEP = "the last accepted step moved no parameter by more than xtol of its std"
    ZERO_GRADIENT = "no step lowers the cost, and the gradient vanishes"
    NO_DECREASE = "no step lowers the cost, yet the gradient does not vanish (model or Jacobian?)"
    MAX_ITER = "ran out of iterations"

    @property
    def converged(self) -> bool:
        """Whether this stop is a minimum."""
        return self in (Status.COST_ROUNDING, Status.SMALL_STEP, Status.ZERO_GRADIENT)


@dataclasses.dataclass(frozen=True)
class Iteration:
    """One iteration of the solver: the cost it started from, the damping of its last try (0 for
    a Gauss-Newton step past the cost's rounding floor, ``identify(finish=True)``), the largest
    step of a parameter in units of its std (``|step| sqrt(A_ii)``), and whether a step was
    taken."""

    cost: float
    damping: float
    step_std: float
    accepted: bool


@dataclasses.dataclass(frozen=True)
class Identification:
    """A solve's result: the state, the kept parameters' values and std by name, the basis, the
    whitened residual RMS (1 when the noise model is right), why it stopped and its trace, and the
    kept parameters' covariance (in ``basis.kept`` order)."""

    state: State  # the problem's own state type
    estimate: dict[str, float]
    std: dict[str, float]
    basis: Basis
    rms: float
    iterations: int
    status: Status = Status.SMALL_STEP
    cov: np.ndarray | None = None
    trace: tuple[Iteration, ...] = ()

    @property
    def converged(self) -> bool:
        """Whether the solve stopped at a minimum (:attr:`Status.converged`)."""
        return self.status.converged


def kept_columns(J, kept: np.ndarray):
    """The kept columns (m, k) of a Jacobian (m, n): ``J[:, kept]`` for a numpy array; a
    scipy.sparse one as it is when every column is kept in order (a structured problem's
    usual basis), else its columns taken as CSC."""
    if not sparse.issparse(J):
        return J[:, kept]
    if len(kept) == J.shape[1] and np.array_equal(kept, np.arange(J.shape[1])):
        return J
    return sparse.csc_matrix(J)[:, kept]


def identify(
    problem: Problem,
    basis: Basis,
    state=None,
    max_iter: int = 50,
    xtol: float = 1e-8,
    rounding: float = COST_ROUNDING,
    finish: bool = False,
    damping: float = 1e-3,
) -> Identification:
    """Levenberg-Marquardt over the kept parameters; std from the whitened normal matrix.

    Converged when the last accepted step moved no parameter by more than ``xtol`` of its std, or
    when even the undamped step would lower the cost by less than the cost's own rounding (then
    no comparison of costs can tell a better state from a worse one: the minimum, to the precision
    the data are summed in). When no step, however damped, lowers the cost, the solve is converged
    only if the gradient vanishes; one that ran out of iterations says so in its status.

    Parameters
    ----------
    problem : the problem (:class:`~calibench.estimators.identification.problem.Problem`).
    basis : which columns to estimate; the others stay where ``state`` has them.
    state : where to start (default ``problem.start()``).
    max_iter, xtol : the iteration limit and the step tolerance (in units of each std).
    rounding : the cost's own rounding, relative to it (default :data:`COST_ROUNDING`): residuals
        that are differences of large numbers (metre lengths measured to the micrometre) sum to a
        cost exact only to about 1e-10 of itself.
    finish : past the rounding floor, take Gauss-Newton's undamped steps (they need no
        comparison of costs) until one moves no parameter by more than ``xtol`` of its std, instead
        of stopping at the floor: the minimum to the precision of the steps, not of the cost.
    damping : Marquardt's first damping (of ``diag(A)``); a start already close to the minimum (a
        consistent estimate to refine) can begin nearly undamped.

    Returns
    -------
    Identification

    Raises
    ------
    numpy.linalg.LinAlgError
        When the kept parameters' normal matrix is singular at the end
        (:func:`~calibench.estimators.identification.covariance.covariance`).
    """
    s = problem.start() if state is None else state
    k = basis.kept
    lam = damping
    r = problem.residuals(s)
    cost = r @ r
    it, status = 0, Status.MAX_ITER
    trace: list[Iteration] = []
    J_s = None  # the kept columns of the Jacobian at s, while s has not moved since
    for it in range(1, max_iter + 1):  # noqa: B007 - the count is reported after the loop
        J_s = kept_columns(problem.jacobian(s), k)
        normal = normal_equations(J_s, r)
        start_cost = float(cost)
        floor = at_rounding_floor(normal, cost, rounding)
        if floor and finish:
            # no comparison of costs can judge a step any more: Gauss-Newton's (undamped) steps,
            # which need none, go on to the minimum until they are below the tolerance
            s, r, cost, moved = gauss_newton_step(problem, s, normal, k)
            J_s = None
            trace.append(Iteration(start_cost, 0.0, moved, True))
            if moved < xtol:
                status = Status.COST_ROUNDING
                break
            continue
        if floor:
            status = Status.COST_ROUNDING
            trace.append(Iteration(start_cost, lam, 0.0, False))
            break
        s, r, cost, lam, moved, accepted = damped_step(problem, s, r, cost, normal, k, lam, xtol)
        trace.append(Iteration(start_cost, lam, moved, accepted))
        if accepted:
            J_s = None
            if moved < xtol:
                status = Status.SMALL_STEP
                break
            continue
        # no step lowers the cost any more (the damped ones, however short): a minimum only if the
        # gradient says so too; a wrong model or Jacobian ends here unconverged
        status = Status.ZERO_GRADIENT if gradient_vanishes(normal, cost) else Status.NO_DECREASE
        break
    # a solve that ends where its last Jacobian was taken (at the cost's rounding floor, or no
    # step taken) has the covariance's Jacobian already: on the arm's fits most do, and each
    # Jacobian of 16,000 postures is a tenth of a second
    return identification_at(problem, basis, s, cost, it, status, tuple(trace), J_s)


def at_rounding_floor(normal: NormalEquations, cost: float, rounding: float) -> bool:
    """Whether even the undamped step would lower the ``cost`` by less than its ``rounding``
    (relative): the most the linearised model promises is the undamped step's decrease,
    g' A^-1 g; a damped step promises less, so only the undamped one may say the minimum is
    reached. False where the normal matrix is singular."""
    try:
        return bool(normal.undamped_decrease() <= rounding * cost)
    except np.linalg.LinAlgError:
        return False


def full_step(problem: Problem, kept: np.ndarray, step_kept: np.ndarray) -> np.ndarray:
    """A step of the kept parameters (k,) as a step of all the problem's (n,), the others 0."""
    step = np.zeros(len(problem.names))
    step[kept] = step_kept
    return step


def step_in_std(step_kept: np.ndarray, diag: np.ndarray) -> float:
    """The largest step (k,) of a kept parameter in units of its std, ``|step| sqrt(A_ii)``."""
    return float(np.max(np.abs(step_kept) * np.sqrt(diag)))


def gauss_newton_step(
    problem: Problem, s, normal: NormalEquations, kept: np.ndarray
) -> tuple[State, np.ndarray, float, float]:
    """Gauss-Newton's undamped step from the state ``s``, taken unjudged.

    Returns
    -------
    state : State
        Where it leads.
    r : ndarray
        (m,) the whitened residuals there.
    cost : float
        Their sum of squares.
    step_std : float
        Its largest step in units of a parameter's std.
    """
    step_k = normal.step(0.0)
    s = problem.update(s, full_step(problem, kept, step_k))
    r = problem.residuals(s)
    return s, r, r @ r, step_in_std(step_k, normal.diag)


def damped_step(
    problem: Problem,
    s,
    r: np.ndarray,
    cost: float,
    normal: NormalEquations,
    kept: np.ndarray,
    lam: float,
    xtol: float,
) -> tuple[State, np.ndarray, float, float, float, bool]:
    """Marquardt's step from the state ``s`` (residuals ``r`` (m,), ``cost``): damped by
    ``lam`` of ``diag(A)``, the damping raised tenfold until a step lowers the cost (then
    lowered tenfold for the next), given up past 1e12 or once a step is below ``xtol`` of the
    parameters' std (shorter ones change nothing either).

    Returns
    -------
    state, r, cost : the state, residuals (m,) and cost after it (``s``'s own if none was taken)
    lam : float
        The damping of the next iteration (taken) or of the last try (not).
    step_std : float
        The last try's largest step in units of a parameter's std.
    accepted : bool
        Whether a step was taken.
    """
    while True:
        step_k = normal.step(lam)
        s_new = problem.update(s, full_step(problem, kept, step_k))
        r_new = problem.residuals(s_new)
        if r_new @ r_new < cost:
            return (
                s_new,
                r_new,
                r_new @ r_new,
                max(lam / 10, 1e-12),
                step_in_std(step_k, normal.diag),
                True,
            )
        if np.max(np.abs(step_k) * np.sqrt(normal.diag)) < xtol:
            break  # a step already below the tolerance: shorter ones change nothing either
        lam *= 10
        if lam > 1e12:
            break
    return s, r, cost, lam, step_in_std(step_k, normal.diag), False


def gradient_vanishes(normal: NormalEquations, cost: float) -> bool:
    """Whether the gradient vanishes at the ``cost``: every component below 1e-6 of the residuals'
    norm (at least 1) in units of its parameter's std."""
    g, diag = normal.g, normal.diag
    return bool(
        np.max(np.abs(g) / np.sqrt(np.maximum(diag, 1e-300))) < 1e-6 * max(np.sqrt(cost), 1.0)
    )


def identification_at(
    problem: Problem,
    basis: Basis,
    s,
    cost: float,
    iterations: int,
    status: Status,
    trace: tuple[Iteration, ...],
    jacobian_kept=None,
) -> Identification:
    """The solve's result at the state ``s`` of whitened ``cost``: the kept parameters' values,
    covariance (raises numpy.linalg.LinAlgError when singular) and std, and the residuals'
    RMS. ``jacobian_kept``: the Jacobian's kept columns at ``s``, where the caller has them
    (computed here otherwise)."""
    k = basis.kept
    J = kept_columns(problem.jacobian(s), k) if jacobian_kept is None else jacobian_kept
    cov, s2 = covariance(J, cost)
    names = problem.names
    values = problem.values(s)
    return Identification(
        state=s,
        estimate={names[j]: float(values[j]) for j in k},
        std={names[j]: float(np.sqrt(cov[i, i])) for i, j in enumerate(k)},
        basis=basis,
        rms=float(np.sqrt(s2)),
        iterations=iterations,
        status=status,
        cov=cov,
        trace=trace,
    )


def identify_identifiable(problem: Problem, note=None) -> Identification:
    """Basis at the start, solve, then the basis again at the solution: a dependence that only
    holds once the model fits (e.g. all points of one cone coinciding) shows there; if the basis
    changes, solve again with it. ``note``: as :func:`identifiable_basis`'s."""
    basis = identifiable_basis(problem, note=note)
    first = identify(problem, basis)
    again = identifiable_basis(problem, first.state, explain=False)
    if set(again.kept) == set(basis.kept):
        return first
    again = identifiable_basis(problem, first.state, note=note)
    # restart from the solution with the newly dropped parameters back at nominal (kept fixed
    # there), so the fit is re-expressed in the new basis rather than carried over
    reset = np.zeros(len(problem.names))
    newly = np.setdiff1d(basis.kept, again.kept)
    reset[newly] = -problem.values(first.state)[newly]
    return identify(problem, again, state=problem.update(first.state, reset))
