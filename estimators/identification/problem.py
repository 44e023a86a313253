"""The identification protocol: a nonlinear least-squares problem in whitened residuals.

A problem holds its data and says how its parameters move the residuals; the solver
(:mod:`calibench.estimators.identification.solver`) and the identifiable basis
(:mod:`calibench.estimators.identification.basis`) need nothing else. A state is whatever the
problem updates (a dataclass of arrays: joint errors, frames, poses); the solver only passes it
back. The arm's problems (:mod:`calibench.estimators.arm.point`,
:mod:`calibench.estimators.arm.tracker`) and the Stewart platform's joint adjustment
(:mod:`calibench.estimators.stewart.adjustment`) implement it.
"""

from __future__ import annotations

import dataclasses
from typing import Any, Protocol

import numpy as np

State = Any  # a problem's own state type, opaque to the solver


class Problem(Protocol):
    """What the solver and the basis ask of a problem (n parameters, m residuals).

    Attributes
    ----------
    names : tuple of str, (n,)
        Every parameter's name, in column order.
    always : ndarray of int
        The columns estimated whatever the data (frames, nuisance parameters).
    groups : list of ndarray of int
        The other columns, group by group: a later group's column that repeats an earlier one's
        effect on the data is the one dropped.
    """

    @property
    def names(self) -> tuple[str, ...]:
        """Every parameter's name, in column order."""
        ...

    @property
    def always(self) -> np.ndarray:
        """The columns estimated whatever the data."""
        ...

    @property
    def groups(self) -> list[np.ndarray]:
        """The other columns, group by group."""
        ...

    def start(self) -> State:
        """The state the solve starts from (the nominal parameters)."""
        ...

    def residuals(self, s: State) -> np.ndarray:
        """Whitened residuals (m,): each divided by its 1-sigma, so 1 is the noise."""
        ...

    def jacobian(self, s: State) -> np.ndarray:
        """d residuals / d step, (m, n), at ``s`` (a step as :meth:`update` applies it): a numpy
        array, or a scipy.sparse matrix for a large structured problem (many nuisance blocks,
        each touching few rows), whose normal equations the solver then factorises sparsely
        (:mod:`calibench.estimators.identification.normal`)."""
        ...

    def update(self, s: State, step: np.ndarray) -> State:
        """The state moved by ``step`` (n,)."""
        ...

    def values(self, s: State) -> np.ndarray:
        """Every parameter's value at ``s``, (n,), in the unit its name says."""
        ...

    def scales(self) -> np.ndarray:
        """(n,) typical sizes of the parameters' errors: they make columns comparable."""
        ...

    def reference(self) -> np.ndarray:
        """(n,) bool: the columns whose largest norm sets the basis's rank tolerance."""
        ...


@dataclasses.dataclass(frozen=True)
class Regrouped:
    """``problem`` with other columns always kept and other groups: the same data, another question
    for the basis (which of these groups' columns do those always-kept ones already explain?)."""

    problem: Problem
    always: np.ndarray
    groups: list[np.ndarray]

    @property
    def names(self) -> tuple[str, ...]:
        """The problem's parameter names."""
        return self.problem.names

    def start(self) -> State:
        """The problem's start."""
        return self.problem.start()

    def residuals(self, s: State) -> np.ndarray:
        """The problem's residuals."""
        return self.problem.residuals(s)

    def jacobian(self, s: State) -> np.ndarray:
        """The problem's Jacobian."""
        return self.problem.jacobian(s)

    def update(self, s: State, step: np.ndarray) -> State:
        """The problem's update."""
        return self.problem.update(s, step)

    def values(self, s: State) -> np.ndarray:
        """The problem's values."""
        return self.problem.values(s)

    def scales(self) -> np.ndarray:
        """The problem's scales."""
        return self.problem.scales()

    def reference(self) -> np.ndarray:
        """The problem's reference columns."""
        return self.problem.reference()
