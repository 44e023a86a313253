"""The one identification solver's sparse path against its dense path, its status and trace, its
covariance test and its Gauss-Newton finish, on a small structured problem with a known truth:
circles of one common radius, each with its own centre (a nuisance block per circle, as a Stewart
platform's poses are), points measured on them with noise."""

import numpy as np
import pytest
from scipy import sparse

from calibench.estimators.identification import normal
from calibench.estimators.identification.basis import Basis, identifiable_basis
from calibench.estimators.identification.covariance import covariance
from calibench.estimators.identification.solver import Status, identify

SIGMA = 0.01  # the points' noise, mm
DENSE_LIMIT = normal.DENSE_LIMIT


class Circles:
    """K circles of one radius: parameters (radius, then each centre's x, y), residuals each
    point's distance to its centre less the radius, over SIGMA; the Jacobian sparse (each point
    moves the radius and its own centre only), or dense with ``dense``."""

    def __init__(self, points, circle, start, dense=False):
        self.p, self.circle, self.x0, self.dense = points, circle, np.asarray(start, float), dense
        K = (len(start) - 1) // 2
        self.names = ("radius",) + tuple(f"c{j}_{a}" for j in range(K) for a in "xy")
        self.n = len(self.names)
        self.always = np.arange(len(self.names))
        self.groups: list[np.ndarray] = []

    def start(self):
        return self.x0

    def _v(self, x):
        centres = x[1:].reshape(-1, 2)[self.circle]
        return self.p - centres

    def residuals(self, x):
        return (np.linalg.norm(self._v(x), axis=1) - x[0]) / SIGMA

    def jacobian(self, x):
        v = self._v(x)
        u = v / np.linalg.norm(v, axis=1)[:, None]
        m = len(u)
        rows = np.repeat(np.arange(m), 3)
        cols = np.c_[np.zeros(m, int), 1 + 2 * self.circle, 2 + 2 * self.circle].ravel()
        data = np.c_[-np.ones(m), -u].ravel() / SIGMA
        J = sparse.csr_matrix((data, (rows, cols)), shape=(m, self.n))
        return J.toarray() if self.dense else J

    def update(self, x, step):
        return x + step

    def values(self, x):
        return x

    def scales(self):
        return np.ones(len(self.names))

    def reference(self):
        return np.ones(len(self.names), bool)


def _circles(K=30, per=8, radius=50.0, seed=0, off=0.5):
    """Truth (radius, centres), the noisy points and a start ``off`` mm away from the truth."""
    rng = np.random.default_rng(seed)
    centres = rng.uniform(-500, 500, (K, 2))
    circle = np.repeat(np.arange(K), per)
    angle = rng.uniform(0, 2 * np.pi, K * per)
    points = centres[circle] + radius * np.c_[np.cos(angle), np.sin(angle)]
    points += rng.normal(0, SIGMA, points.shape)
    truth = np.r_[radius, centres.ravel()]
    return truth, points, circle, truth + rng.uniform(-off, off, len(truth))


def _every(problem):
    return Basis(kept=np.arange(len(problem.names)), dropped={})


@pytest.mark.parametrize("limit", [DENSE_LIMIT, 0])
def test_the_sparse_path_is_the_dense_path(limit, monkeypatch):
    """Same problem, the Jacobian sparse or dense: the same estimate and covariance (1e-9
    relative), both converged, both recovering the truth within 5 std (the std from SIGMA); the
    sparse path's normal matrix factorised densely (61 columns) or, with no columns allowed
    that, by SuperLU."""
    monkeypatch.setattr(normal, "DENSE_LIMIT", limit)
    truth, points, circle, start = _circles()
    sp = identify(Circles(points, circle, start), _every(Circles(points, circle, start)))
    de = identify(
        Circles(points, circle, start, dense=True), _every(Circles(points, circle, start))
    )
    assert sp.converged and de.converged
    est_sp, est_de = np.array(list(sp.estimate.values())), np.array(list(de.estimate.values()))
    np.testing.assert_allclose(est_sp, est_de, rtol=1e-9, atol=1e-9 * SIGMA)
    np.testing.assert_allclose(sp.cov, de.cov, rtol=1e-9, atol=1e-9 * np.abs(de.cov).max())
    assert sp.rms == pytest.approx(de.rms, rel=1e-9)
    std = np.array(list(sp.std.values()))
    assert np.all(np.abs(est_sp - truth) < 5 * std)
    assert 0.8 < sp.rms < 1.2  # the noise is SIGMA
    # the radius, seen by 240 points: SIGMA / sqrt(240 - 60 centres' worth) or so
    assert sp.std["radius"] == pytest.approx(SIGMA / np.sqrt(240), rel=0.2)


@pytest.mark.parametrize("dense", [False, True])
def test_a_solve_cut_short_says_so_in_its_status_and_trace(dense):
    """Two iterations from 20 mm off: ran out of iterations (not converged), and the trace has
    both, each starting from the cost the one before left, every step taken and lowering it."""
    truth, points, circle, start = _circles(off=20.0)
    problem = Circles(points, circle, start, dense=dense)
    cut = identify(problem, _every(problem), max_iter=2)
    assert cut.status is Status.MAX_ITER and not cut.converged and cut.iterations == 2
    assert len(cut.trace) == 2 and all(it.accepted for it in cut.trace)
    r0 = problem.residuals(start)
    assert cut.trace[0].cost == pytest.approx(r0 @ r0)
    assert cut.trace[1].cost < cut.trace[0].cost
    assert cut.trace[1].damping < cut.trace[0].damping  # an accepted step relaxes the damping
    assert cut.rms**2 * (len(r0) - len(problem.names)) < cut.trace[1].cost
    full = identify(problem, _every(problem))
    assert full.converged and full.iterations > 2
    assert np.max(np.abs(full.state - truth) / np.array(list(full.std.values()))) < 5


@pytest.mark.parametrize("dense", [False, True])
def test_columns_that_repeat_each_other_are_an_error_in_both_paths(dense):
    """A second radius column (the same effect as the first): the normal matrix is singular,
    and the covariance says so whichever path factorises it."""
    truth, points, circle, _ = _circles(K=5)
    J = Circles(points, circle, truth).jacobian(truth)
    twice = sparse.hstack([J[:, :1], J]).tocsr()
    with pytest.raises(np.linalg.LinAlgError, match="singular"):
        covariance(twice.toarray() if dense else twice, float(len(points)))
    still = sparse.hstack([sparse.csr_matrix((len(points), 1)), J]).tocsr()  # moves nothing
    with pytest.raises(np.linalg.LinAlgError, match="singular"):
        covariance(still.toarray() if dense else still, float(len(points)))


def test_the_gauss_newton_finish_reaches_the_minimum_the_floor_stops_short_of():
    """Told the cost is exact only to 1e-4 of itself, the solver stops at that floor (a
    minimum to what costs can say); finishing with Gauss-Newton steps past it reaches the minimum
    a fully converged solve finds, to 1e-6 of the std."""
    truth, points, circle, start = _circles(off=2.0)
    problem = Circles(points, circle, start)
    tight = identify(problem, _every(problem), xtol=1e-10, rounding=1e-15, finish=True)
    std = np.sqrt(np.diag(tight.cov))
    coarse = identify(problem, _every(problem), rounding=1e-4)
    finished = identify(problem, _every(problem), xtol=1e-6, rounding=1e-4, finish=True)
    assert coarse.status is Status.COST_ROUNDING and finished.status is Status.COST_ROUNDING
    assert np.max(np.abs(coarse.state - tight.state) / std) > 1e-3
    assert np.max(np.abs(finished.state - tight.state) / std) < 1e-6
    undamped = [it for it in finished.trace if it.damping == 0.0]
    assert undamped and all(it.accepted for it in undamped)


class TwoRadii(Circles):
    """:class:`Circles` with a second radius column, in a group after the centres."""

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.names += ("radius_again",)
        self.always, self.groups = np.array([0]), [np.arange(1, len(self.names))]

    def jacobian(self, x):
        J = super().jacobian(x[:-1])
        return np.hstack([J, J[:, :1]]) if self.dense else sparse.hstack([J, J[:, :1]]).tocsr()

    def scales(self):
        return np.ones(len(self.names))

    def reference(self):
        return np.ones(len(self.names), bool)


def test_a_sparse_jacobian_gets_the_same_basis():
    """The identifiable basis of a sparse Jacobian is the dense one's (its QR is dense): a
    second radius column, in the centres' group, is the one dropped, as the radius."""
    truth, points, circle, start = _circles(K=4)
    a, b = (identifiable_basis(TwoRadii(points, circle, np.r_[start, 0.0], d)) for d in (0, 1))
    assert np.array_equal(a.kept, b.kept) and list(a.dropped) == list(b.dropped)
    assert list(a.dropped) == ["radius_again"] and "radius (+1.00)" in a.dropped["radius_again"]
