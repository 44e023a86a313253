"""The normal equations of one Levenberg-Marquardt iteration, dense or sparse.

A problem's Jacobian is a numpy array (the arm's problems: a few hundred rows, a few dozen
columns) or a scipy.sparse matrix (a large structured problem: the Stewart platform's joint
adjustment has six columns per pose, each pose's rows touching only its own six, the stations'
and the legs'). The solver asks both kinds the same three things: the diagonal of ``A = J^T J``,
the undamped step's promised decrease ``g^T A^-1 g`` and the step damped by Marquardt's
``lam diag(A)``. The dense kind does it as it always has; the sparse kind forms ``A`` sparsely
(the dense product's cost is what a large problem cannot pay), scales it to a unit diagonal,
where Marquardt's damping is ``lam I``, and factorises it (LAPACK's Cholesky up to
:data:`DENSE_LIMIT` columns, SuperLU beyond). :func:`inverse_normal` is the sparse kind's
covariance.
"""

from __future__ import annotations

from typing import Protocol

import numpy as np
from scipy import sparse
from scipy.linalg import lapack
from scipy.sparse import linalg as splinalg

# Up to this many columns a scaled normal matrix is factorised densely (LAPACK's Cholesky of a
# 400-column matrix takes a third less time than SuperLU's, and forming it sparsely is what saves
# the dense path's cost); beyond it, sparsely, where the dense cost (cubic) would dominate.
DENSE_LIMIT = 2000


class NormalEquations(Protocol):
    """``A = J^T J`` and ``g = J^T r`` of the kept columns (k of them) at one state.

    Attributes
    ----------
    diag : ndarray, (k,)
        The diagonal of ``A``: a step's size in units of each parameter's std is
        ``|step| sqrt(diag)``.
    g : ndarray, (k,)
        The gradient of half the cost.
    """

    diag: np.ndarray
    g: np.ndarray

    def undamped_decrease(self) -> float:
        """``g^T A^-1 g``, the most the linearised model promises; raises
        ``numpy.linalg.LinAlgError`` when ``A`` is exactly singular."""
        ...

    def step(self, lam: float) -> np.ndarray:
        """The Levenberg-Marquardt step (k,), ``-(A + lam diag(A))^-1 g``."""
        ...


class DenseNormal:
    """The normal equations of a dense Jacobian ``J`` (m, k) and residuals ``r`` (m,)."""

    def __init__(self, J: np.ndarray, r: np.ndarray):
        self.A, self.g = J.T @ J, J.T @ r
        self.diag = np.diag(self.A)

    def undamped_decrease(self) -> float:
        """``g^T A^-1 g`` by LAPACK's solve."""
        return self.g @ np.linalg.solve(self.A, self.g)

    def step(self, lam: float) -> np.ndarray:
        """``-(A + lam diag(A))^-1 g`` by LAPACK's solve."""
        return -np.linalg.solve(self.A + lam * np.diag(np.diag(self.A)), self.g)


def solve_spd(M: sparse.spmatrix, rhs: np.ndarray) -> np.ndarray:
    """``M^-1 rhs`` for a symmetric positive definite ``M`` (k, k) with a unit diagonal (the
    scaled normal matrix) and rhs (k,): LAPACK's dense Cholesky up to :data:`DENSE_LIMIT`
    columns, SuperLU beyond (a fill-reducing column order applied to the rows too, the diagonal
    as pivots: Cholesky's factorisation in LU form). Raises ``numpy.linalg.LinAlgError`` when
    ``M`` is not positive definite to working precision (dense) or a pivot is exactly zero
    (sparse)."""
    if M.shape[0] <= DENSE_LIMIT:
        U, info = lapack.dpotrf(M.toarray(), lower=False, clean=False)
        if info != 0:
            raise np.linalg.LinAlgError(
                f"the normal matrix is not positive definite (potrf {info})"
            )
        return lapack.dpotrs(U, rhs, lower=False)[0]
    try:
        lu = splinalg.splu(
            sparse.csc_matrix(M),
            permc_spec="COLAMD",
            diag_pivot_thresh=0.0,
            options={"SymmetricMode": True},
        )
    except RuntimeError as e:  # SuperLU's "Factor is exactly singular"
        raise np.linalg.LinAlgError(str(e)) from e
    return lu.solve(rhs)


def unit_diagonal(J: sparse.spmatrix) -> tuple[sparse.csr_matrix, np.ndarray]:
    """``J`` (m, k) with its columns scaled to unit norm, ``J D`` with ``D = diag(A)^-1/2``
    (``A = J^T J``, so ``D A D`` has a unit diagonal), and D's diagonal (k,). A zero column (a
    parameter that does not move the data) keeps its zero, and a zero in D.

    The columns of a problem mix units (mm and rad, a station and a rotation): scaled alike, a
    factorisation's pivots and Marquardt's damping weigh each as the data move under it."""
    J = sparse.csr_matrix(J)
    norm2 = np.bincount(J.indices, J.data**2, minlength=J.shape[1])
    d = np.where(norm2 > 0, 1 / np.sqrt(np.where(norm2 > 0, norm2, 1.0)), 0.0)
    return sparse.csr_matrix((J.data * d[J.indices], J.indices, J.indptr), J.shape), d


class SparseNormal:
    """The normal equations of a sparse Jacobian ``J`` (m, k) and residuals ``r`` (m,), formed
    sparsely and solved on ``D A D``, ``A`` scaled to a unit diagonal (:func:`unit_diagonal`),
    where Marquardt's damping ``lam diag(A)`` is ``lam I`` (:func:`solve_spd`)."""

    def __init__(self, J: sparse.spmatrix, r: np.ndarray):
        Js, self.d = unit_diagonal(J)
        self.As = sparse.csc_matrix(Js.T @ Js)
        self.gs = Js.T @ r  # the gradient on the scaled columns, D g
        with np.errstate(divide="ignore"):
            self.diag = np.where(self.d > 0, 1 / self.d**2, 0.0)
            self.g = np.where(self.d > 0, self.gs / self.d, 0.0)
        self._undamped: np.ndarray | None = None  # (D A D)^-1 D g, once solved

    def _solve(self, lam: float) -> np.ndarray:
        """``(D A D + lam I)^-1 D g``; the undamped one kept for a Gauss-Newton step."""
        if lam == 0.0 and self._undamped is not None:
            return self._undamped
        M = self.As if lam == 0.0 else self.As + lam * sparse.identity(len(self.d), format="csc")
        x = solve_spd(M, self.gs)
        if lam == 0.0:
            self._undamped = x
        return x

    def undamped_decrease(self) -> float:
        """``g^T A^-1 g`` (on the scaled columns, where it is the same number)."""
        return float(self.gs @ self._solve(0.0))

    def step(self, lam: float) -> np.ndarray:
        """``-(A + lam diag(A))^-1 g``: on the scaled columns ``-(D A D + lam I)^-1 D g``,
        scaled back by D."""
        return -self.d * self._solve(lam)


def normal_equations(J, r: np.ndarray) -> NormalEquations:
    """:class:`SparseNormal` for a scipy.sparse Jacobian, :class:`DenseNormal` otherwise."""
    return SparseNormal(J, r) if sparse.issparse(J) else DenseNormal(J, r)


def inverse_normal(J: sparse.spmatrix, last: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """``(J^T J)^-1`` (k, k) of a sparse Jacobian (m, k), or its block of the ``last`` columns
    (last, last), and those columns' variance inflations, ``(A^-1)_ii A_ii``: the diagonal of the
    inverse of the unit-diagonal normal matrix (:func:`unit_diagonal`), which is what is inverted.

    The normal matrix is formed sparsely; its inverse is dense (a covariance of k parameters is
    k x k whatever the sparsity), by LAPACK's Cholesky factorisation ``U^T U`` and inverse (potrf,
    potri): a sparse factorisation's solve for k right-hand sides is many times slower. The last
    columns' block alone is ``U22^-1 U22^-T``, U22 the factor's last diagonal block (the other
    columns are eliminated before them). A matrix that is not positive definite to working
    precision (a zero column, a zero or negative pivot) gives NaN inflations, for the caller's
    test."""
    Js, d = unit_diagonal(J)
    k = len(d)
    n = k if last is None else last
    U, info = lapack.dpotrf((Js.T @ Js).toarray(), lower=False, clean=True)
    regular = info == 0 and bool(np.all(d > 0))
    if regular and last is None:
        # potri fills the upper triangle; the lower one is U's, which clean=True zeroed
        inv_s, info = lapack.dpotri(U, lower=False)
        inv_s += np.triu(inv_s, 1).T
    elif regular:
        U22_inv, info = lapack.dtrtri(U[k - n :, k - n :], lower=False)
        inv_s = U22_inv @ U22_inv.T
    if not regular or info != 0:
        inv_s = np.full((n, n), np.nan)
    return inv_s * np.outer(d[k - n :], d[k - n :]), np.diag(inv_s).copy()
