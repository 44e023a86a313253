"""A 6-6 Stewart platform's kinematics: the legs' lengths of a pose, and the pose of six lengths.

A pose is (R (3, 3), t (3,)) mapping platform-frame points into the base frame; leg i joins
the base hinge B_i to the platform hinge r_i (platform frame), its length |R r_i + t - B_i|.
"""

from __future__ import annotations

import numpy as np

from calibench.estimators.rotations import rotvec_to_matrix
from calibench.estimators.stewart.tracker import CONVERGED_STEP


def leg_lengths(R: np.ndarray, t: np.ndarray, r: np.ndarray, B: np.ndarray) -> np.ndarray:
    """Hinge-to-hinge lengths (6,) of a pose, r and B (6, 3)."""
    return np.linalg.norm(r @ R.T + t - B, axis=1)


def leg_derivatives(R: np.ndarray, u: np.ndarray) -> np.ndarray:
    """d |R r_i + t - B_i| - l_i / d (r_i, B_i, l_i), (n, 6, 7), at poses R (n, 3, 3) whose legs
    point along u (n, 6, 3) from the base hinge: u^T R, -u^T and -1."""
    uR = np.einsum("nli,nij->nlj", u, R)
    return np.concatenate([uR, -u, np.full(u.shape[:2] + (1,), -1.0)], axis=2)


def leg_conditions(
    r: np.ndarray, B: np.ndarray, R: np.ndarray, t: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The legs' lengths (n, 6) mm and the condition numbers (n,) of their Jacobian at poses
    R (n, 3, 3), t (n, 3), for platform hinges r (6, 3) and base hinges B (6, 3): rows
    (u, (R r) x u / rho), u the leg's unit vector, rho the platform's hinge radius (so turns and
    shifts weigh alike). A pose where a leg has no length (or no finite one) has condition inf."""
    arm = np.einsum("nij,kj->nki", R, r)  # (n, 6, 3)
    v = arm + t[:, None] - B
    L = np.linalg.norm(v, axis=2)
    rho = float(np.max(np.linalg.norm(r, axis=1)))
    with np.errstate(all="ignore"):
        u = v / L[..., None]
        J = np.concatenate([u, np.cross(arm, u) / rho], axis=2)
        sv = np.linalg.svd(np.nan_to_num(J, nan=0.0, posinf=0.0, neginf=0.0), compute_uv=False)
        cond = np.where(sv[:, -1] > 0, sv[:, 0] / sv[:, -1], np.inf)
    return L, cond


def forward_kinematics(
    lengths: np.ndarray,
    r: np.ndarray,
    B: np.ndarray,
    R0: np.ndarray,
    t0: np.ndarray,
    iterations: int = 30,
) -> tuple[np.ndarray, np.ndarray, bool]:
    """The pose whose legs have ``lengths`` (6,), Newton from (R0, t0) (left rotation updates),
    and whether Newton converged."""
    R, t = np.array(R0, float), np.array(t0, float)
    step = np.full(6, np.inf)
    for _ in range(iterations):
        p = r @ R.T + t
        v = p - B
        L = np.linalg.norm(v, axis=1)
        u = v / L[:, None]
        Rr = r @ R.T
        J = np.c_[np.cross(Rr, u), u]  # d L / d(omega, t): u . (omega x Rr) = omega . (Rr x u)
        step = np.linalg.solve(J, lengths - L)
        R = rotvec_to_matrix(step[:3]) @ R
        t = t + step[3:]
        if np.max(np.abs(step)) < 1e-13:
            break
    return R, t, bool(np.max(np.abs(step)) < CONVERGED_STEP)


def forward_kinematics_many(
    lengths: np.ndarray,
    r: np.ndarray,
    B: np.ndarray,
    R0: np.ndarray,
    t0: np.ndarray,
    iterations: int = 30,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`forward_kinematics` for many leg-length sets (n, 6) at once, each from (R0, t0):
    poses R (n, 3, 3), t (n, 3) and whether each converged (n,). A set no pose can take (a
    negative length, a singularity on the way) is one that did not converge; the others go on."""
    lengths = np.asarray(lengths, float)
    n = len(lengths)
    R, t = (
        np.repeat(np.asarray(R0, float)[None], n, axis=0),
        np.repeat(np.asarray(t0, float)[None], n, axis=0),
    )
    step = np.full((n, 6), np.inf)
    lost = np.zeros(
        n, bool
    )  # poses whose iteration left the finite numbers: not converged, and frozen
    for _ in range(iterations):
        Rr = np.einsum("nij,kj->nki", R, r)  # (n, 6, 3)
        v = Rr + t[:, None] - B
        L = np.linalg.norm(v, axis=2)
        with np.errstate(invalid="ignore", divide="ignore"):
            u = v / L[..., None]
        J = np.concatenate([np.cross(Rr, u), u], axis=2)  # (n, 6, 6)
        rhs = lengths - L
        lost |= ~(np.isfinite(J).all(axis=(1, 2)) & np.isfinite(rhs).all(axis=1))
        J[lost], rhs[lost] = np.eye(6), 0.0
        try:
            step = np.linalg.solve(J, rhs[..., None])[..., 0]
        except np.linalg.LinAlgError:  # a pose at a singularity must not stop the others
            step = np.einsum("nij,nj->ni", np.linalg.pinv(J), rhs)
        R = np.einsum("nij,njk->nik", rotvec_to_matrix(step[:, :3]), R)
        t = t + step[:, 3:]
        if np.max(np.abs(step)) < 1e-13:
            break
    return R, t, (np.max(np.abs(step), axis=1) < CONVERGED_STEP) & ~lost
