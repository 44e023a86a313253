"""An arm's positioning repeatability from the postures a recording visits more than once.

ISO 9283's repeatability of a pose is ``RP = l_mean + 3 S_l``, ``l_j = |x_j - mean x|`` over
the cycles j (clause 7.2.2). A recording that returns to the same commanded posture a few times
(two or three, not the standard's 30) holds the same scatter, pooled over its postures: each
group's points less their own mean give the within-group covariance::

    C = sum_g sum_(i in g) (x_i - mean_g)(x_i - mean_g)^T / sum_g (n_g - 1)

with ``3 sum_g (n_g - 1)`` degrees of freedom over its diagonal. The RP the standard would
report for a pose of that scatter at ``cycles`` cycles is the expectation of ``l_mean + 3 S_l``
over Gaussian attained points of covariance C, taken by a fixed draw (no closed form for an
anisotropic C; 3.616 s for an isotropic one of s per axis as the cycles grow).

Pure numpy and scipy; rows are 0-based data rows.
"""

from __future__ import annotations

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree


def repeat_groups(q_rad: np.ndarray, q_tol_deg: float = 0.05) -> np.ndarray:
    """Each row's group of repeated postures (every joint within ``q_tol_deg`` of another row
    of the group), (n,) int; -1 for a posture visited once.

    Parameters
    ----------
    q_rad : ndarray, (n, N)
        The joint readings.
    q_tol_deg : float
        How far two readings of one commanded posture may lie apart, per joint.
    """
    q = np.degrees(np.asarray(q_rad, float))
    n = len(q)
    pairs = cKDTree(q).query_pairs(q_tol_deg, p=np.inf, output_type="ndarray") if n > 1 else []
    pairs = np.asarray(pairs, int).reshape(-1, 2)
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    _, label = connected_components(graph, directed=False)
    size = np.bincount(label)
    return np.where(size[label] > 1, label, -1)


def pooled_covariance(xyz_mm: np.ndarray, groups: np.ndarray) -> tuple[np.ndarray, int]:
    """The within-group covariance of the measured points, pooled over the groups.

    Parameters
    ----------
    xyz_mm : ndarray, (n, 3)
    groups : ndarray, (n,) int
        :func:`repeat_groups`' labels (-1: left out).

    Returns
    -------
    cov : ndarray, (3, 3) mm^2
    dof : int
        sum_g (n_g - 1), per coordinate.
    """
    y = np.asarray(xyz_mm, float)
    keep = groups >= 0
    labels, index, counts = np.unique(groups[keep], return_inverse=True, return_counts=True)
    dof = int(np.sum(counts - 1))
    if dof == 0:
        raise ValueError("no posture is visited twice: no repeatability to pool")
    means = np.zeros((len(labels), 3))
    np.add.at(means, index, y[keep])
    r = y[keep] - means[index] / counts[index, None]
    return r.T @ r / dof, dof


def group_scatter_mm(xyz_mm: np.ndarray, groups: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each group's label and RMS distance of its points from their mean, (G,) each."""
    y = np.asarray(xyz_mm, float)
    keep = groups >= 0
    labels, index, counts = np.unique(groups[keep], return_inverse=True, return_counts=True)
    means = np.zeros((len(labels), 3))
    np.add.at(means, index, y[keep])
    d2 = np.sum((y[keep] - means[index] / counts[index, None]) ** 2, axis=1)
    ss = np.bincount(index, d2, len(labels))
    return labels, np.sqrt(ss / np.maximum(counts - 1, 1))


def expected_rp(
    cov_mm2: np.ndarray, cycles: int = 30, draws: int = 20_000, seed: int = 9283
) -> float:
    """The expectation of ISO 9283's RP (mm) at ``cycles`` cycles of a pose whose attained points
    scatter as N(0, ``cov_mm2``), over ``draws`` fixed simulated tests.

    Parameters
    ----------
    cov_mm2 : ndarray, (3, 3)
    cycles : int
    draws : int
    seed : int
        The draw's (the figure is a function of C alone).
    """
    L = np.linalg.cholesky(np.asarray(cov_mm2, float) + 1e-30 * np.eye(3))
    x = np.random.default_rng(seed).standard_normal((draws, cycles, 3)) @ L.T
    l_j = np.linalg.norm(x - x.mean(axis=1, keepdims=True), axis=2)
    return float(np.mean(l_j.mean(axis=1) + 3 * l_j.std(axis=1, ddof=1)))
