"""What a fit of an arm leaves out, read from its residuals (measured minus modelled points):
a periodic error of the joints' angles (a gear's or an encoder's, at a frequency in cycles per
turn common to several joints) and how the error depends on the move that came before a row.

Units: angles rad (moves deg, as a user reads them), lengths mm, frequencies cycles per turn
(a harmonic of the joint's angle: sin(f q) with q in rad).
"""

from __future__ import annotations

import numpy as np

from calibench.estimators.arm.kinematics import Chain, jacobian, theta_index


def angle_jacobian(
    chain: Chain, q_rad: np.ndarray, joints, frame_rotation: np.ndarray | None = None
) -> np.ndarray:
    """How the tool point moves with each of ``joints``' angles, in a measuring frame.

    Parameters
    ----------
    chain : Chain
        The arm.
    q_rad : (n, N) array
        The joint readings.
    joints : sequence of int, (k,)
        1-based joint numbers.
    frame_rotation : (3, 3) array, optional
        Base to the residuals' frame (a fit's base registration); identity if None.

    Returns
    -------
    (n, 3, k) array
        d(point) / d(q_j) in the residuals' frame (mm/rad).
    """
    J = jacobian(chain, q_rad)[:, :, [theta_index(j) for j in joints]]
    if frame_rotation is None:
        return J
    return np.einsum("ab,nbj->naj", frame_rotation, J)


def joint_angle_periodogram(
    jac_mm_per_rad: np.ndarray, resid_mm: np.ndarray, q_rad: np.ndarray, freqs: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """One angle error at a common frequency on k joints, fitted at each trial frequency.

    Model: joint j's angle is off by s_j sin(f q_j) + c_j cos(f q_j) (rad), which moves the point
    by ``jac[:, :, j]`` times that; at each f, (s, c) by linear least squares on every row's
    three coordinates. The gain is how much that fit lowers the residuals' sum of squares, so
    the frequency of the largest gain is the error's (a periodogram through the Jacobian).

    Parameters
    ----------
    jac_mm_per_rad : (n, 3, k) array
        d(point) / d(q_j) in the residuals' frame (:func:`angle_jacobian`).
    resid_mm : (n, 3) array
        Measured minus modelled points.
    q_rad : (n, k) array
        The k joints' angles.
    freqs : (F,) array
        Trial frequencies (cycles per turn).

    Returns
    -------
    gain_mm2 : (F,) array
        The drop of the residuals' sum of squares (mm^2) at each frequency.
    coef_rad : (F, 2 k) array
        The fitted (s_1..s_k, c_1..c_k) at each frequency (rad).
    """
    Jq, e = jac_mm_per_rad, resid_mm
    # normal equations of the sine and cosine columns, from per-row products: a frequency
    # costs O(n k^2) instead of forming the (3 n, 2 k) design matrix
    G = np.tile(np.einsum("naj,nak->njk", Jq, Jq), (1, 2, 2))  # (n, 2k, 2k)
    h = np.tile(np.einsum("naj,na->nj", Jq, e), (1, 2))  # (n, 2k)
    gain, coef = [], []
    for f in freqs:
        W = np.concatenate([np.sin(f * q_rad), np.cos(f * q_rad)], axis=1)
        b = np.einsum("nj,nj->j", h, W)
        c = np.linalg.solve(np.einsum("njk,nj,nk->jk", G, W, W), b)
        gain.append(b @ c)
        coef.append(c)
    return np.array(gain), np.array(coef)


def harmonic_amplitude_phase(coef_rad: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A harmonic's amplitude and phase per joint from its sine and cosine coefficients.

    Parameters
    ----------
    coef_rad : (2 k,) array
        (s_1..s_k, c_1..c_k) of :func:`joint_angle_periodogram` at one frequency.

    Returns
    -------
    amplitude_rad : (k,) array
        A_j, with s_j sin(f q) + c_j cos(f q) = A_j sin(f q + phi_j).
    phase_rad : (k,) array
        phi_j in (-pi, pi].
    """
    k = len(coef_rad) // 2
    s, c = coef_rad[:k], coef_rad[k:]
    return np.hypot(s, c), np.arctan2(c, s)


def largest_joint_move_deg(q_rad: np.ndarray) -> np.ndarray:
    """Each row's move from the row before: the largest travel of any joint (deg).

    Parameters
    ----------
    q_rad : (N, J) array
        The joint readings in recording order.

    Returns
    -------
    (N,) array
        max_j |q[i, j] - q[i - 1, j]| in degrees; 0 for the first row.
    """
    return np.r_[0.0, np.degrees(np.abs(np.diff(q_rad, axis=0)).max(axis=1))]


def error_after_moves(
    err_mm: np.ndarray, move_deg: np.ndarray, threshold_deg: float
) -> tuple[float, float]:
    """The mean error after a large move and after a small one.

    Parameters
    ----------
    err_mm : (n,) array
        Each row's error (the norm of its residual, mm).
    move_deg : (n,) array
        The move before each row (:func:`largest_joint_move_deg`, deg).
    threshold_deg : float
        A move larger than this is large.

    Returns
    -------
    tuple of float
        Mean error of the rows after a move larger than ``threshold_deg``, and of the others
        (mm); nan where there are none.
    """
    large = move_deg > threshold_deg
    after_large = err_mm[large].mean() if large.any() else np.nan
    after_small = err_mm[~large].mean() if (~large).any() else np.nan
    return float(after_large), float(after_small)
