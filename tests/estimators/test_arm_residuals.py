"""What a fit leaves out, read from its residuals (estimators/arm/residuals.py): a joint-angle
harmonic of known frequency, amplitudes and phases recovered through a Jacobian from noisy
residuals, and the error after large moves of a recording whose moves and errors are known."""

import numpy as np

from calibench.estimators.arm.residuals import (
    error_after_moves,
    harmonic_amplitude_phase,
    joint_angle_periodogram,
    largest_joint_move_deg,
)


def test_the_periodogram_finds_a_joint_harmonic_its_amplitudes_and_phases():
    """Residuals made of one angle error at 17.1 cycles per turn on three joints (each its own
    amplitude and phase) through a random Jacobian, plus 10 um of noise. The peak is the true
    frequency (its Cramer-Rao std is about 0.002 cycles per turn, a fifth of the grid's step);
    the amplitudes and phases are within 5 std of the least-squares fit's own covariance at that
    frequency; the gain is the signal's energy within 5 std of its noise term."""
    rng = np.random.default_rng(3)
    n, k, sigma_mm = 2000, 3, 0.01
    f0, amp, phase = 17.1, np.array([2e-4, 1e-4, 3e-4]), np.array([0.3, -1.2, 2.5])
    jac = rng.normal(0.0, 300.0, (n, 3, k))  # mm/rad
    q = rng.uniform(-np.pi, np.pi, (n, k))
    dq = amp * np.sin(f0 * q + phase)  # (n, k) rad
    signal = np.einsum("naj,nj->na", jac, dq)
    resid = signal + rng.normal(0.0, sigma_mm, (n, 3))
    freqs = np.arange(500, 3001) / 100

    gain, coef = joint_angle_periodogram(jac, resid, q, freqs)

    peak = int(np.argmax(gain))
    assert abs(freqs[peak] - f0) < 1e-9
    # the fit's covariance at the peak: sigma^2 (X^T X)^-1 of the (3 n, 2 k) design
    X = np.concatenate([jac * np.sin(f0 * q)[:, None], jac * np.cos(f0 * q)[:, None]], axis=2)
    X = X.reshape(3 * n, 2 * k)
    std = sigma_mm * np.sqrt(np.diag(np.linalg.inv(X.T @ X)))
    got_amp, got_phase = harmonic_amplitude_phase(coef[peak])
    per_joint = np.maximum(std[:k], std[k:])
    np.testing.assert_array_less(np.abs(got_amp - amp), 5 * per_joint)
    np.testing.assert_array_less(
        np.abs(np.angle(np.exp(1j * (got_phase - phase)))), 5 * per_joint / amp
    )
    energy = float(np.sum(signal**2))
    assert abs(gain[peak] - energy) < 5 * 2 * sigma_mm * np.sqrt(energy) + 2 * k * sigma_mm**2


def test_amplitude_and_phase_rebuild_the_harmonic():
    """s sin + c cos = A sin(. + phi) at any angle, for the A and phi returned."""
    coef = np.array([3.0, -1.0, 0.5, 2.0])  # s1, s2, c1, c2
    amp, phase = harmonic_amplitude_phase(coef)
    x = np.linspace(-4, 4, 9)[:, None]
    np.testing.assert_allclose(
        coef[:2] * np.sin(x) + coef[2:] * np.cos(x), amp * np.sin(x + phase), atol=1e-12
    )


def test_the_error_after_large_moves_is_told_from_the_error_after_small_ones():
    """A recording whose rows follow moves drawn here: small ones (every joint within 20 deg) and,
    before a quarter of the rows, one joint swung 70-150 deg; the rows' error is 0.40 mm after a
    large move and 0.25 mm after a small one, with 0.05 mm of scatter, and 30 % of the rows are
    scored. The moves are recovered exactly and each mean within 5 standard errors."""
    rng = np.random.default_rng(5)
    N, J, scatter = 3000, 6, 0.05
    step_deg = rng.uniform(-20, 20, (N, J))
    swing = rng.random(N) < 0.25
    joint = rng.integers(0, J, N)
    step_deg[swing, joint[swing]] = rng.choice([-1, 1], swing.sum()) * rng.uniform(
        70, 150, swing.sum()
    )
    step_deg[0] = 0.0
    swing[0] = False
    q = np.radians(np.cumsum(step_deg, axis=0))

    move = largest_joint_move_deg(q)
    np.testing.assert_allclose(move, np.abs(step_deg).max(axis=1), atol=1e-9)

    err = np.where(swing, 0.40, 0.25) + rng.normal(0.0, scatter, N)
    scored = rng.random(N) < 0.3
    large, small = error_after_moves(err[scored], move[scored], 60)
    n_large, n_small = (swing & scored).sum(), (~swing & scored).sum()
    assert abs(large - 0.40) < 5 * scatter / np.sqrt(n_large)
    assert abs(small - 0.25) < 5 * scatter / np.sqrt(n_small)
