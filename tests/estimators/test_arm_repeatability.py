"""An arm's repeatability pooled from a recording's repeated postures (issue 64): groups found
by the joints alone, the pooled covariance a known scatter's, and the RP it states ISO 9283's
own (estimators/arm/repeatability.py)."""

import numpy as np
import pytest

from calibench.estimators.arm.repeatability import (
    expected_rp,
    group_scatter_mm,
    pooled_covariance,
    repeat_groups,
)
from calibench.scenarios.arm_cmm.acceptance import pose_figures

CHI3 = np.sqrt(8 / np.pi) + 3 * np.sqrt(3 - 8 / np.pi)  # RP / s of an isotropic scatter, n -> inf


def _visits(rng, postures: int, repeats: np.ndarray, q_scatter_deg: float) -> np.ndarray:
    """Joint readings (n, 6) rad: ``postures`` commanded postures, each read ``repeats[i]``
    times within ``q_scatter_deg``."""
    commanded = rng.uniform(-170, 170, (postures, 6))
    q = np.repeat(commanded, repeats, axis=0) + rng.uniform(-1, 1, (repeats.sum(), 6)) * (
        q_scatter_deg
    )
    return np.radians(q)


def test_repeats_are_grouped_by_their_joints_alone():
    """Postures read within the tolerance fall in one group, each other posture alone; a posture
    0.1 deg off another is another posture."""
    rng = np.random.default_rng(1)
    repeats = rng.integers(1, 4, 300)
    q = _visits(rng, 300, repeats, 0.01)
    groups = repeat_groups(q, 0.05)
    truth = np.repeat(np.arange(300), repeats)
    for g in range(300):
        rows = truth == g
        if repeats[g] == 1:
            assert groups[rows][0] == -1
        else:
            assert len(set(groups[rows])) == 1 and groups[rows][0] >= 0
            assert not np.any(groups[~rows] == groups[rows][0])
    off = np.vstack([q[:1], q[:1] + np.radians(0.1)])
    assert np.all(repeat_groups(off, 0.05) == -1)


def test_the_pooled_covariance_is_the_scatter_planted():
    """Points of groups of two and three scattered N(0, diag(s^2)) about each posture's own
    place: each std within 4 of its relative error 1 / sqrt(2 dof), whatever the places."""
    rng = np.random.default_rng(2)
    repeats = rng.integers(2, 4, 400)
    s = np.array([0.010, 0.020, 0.015])
    places = rng.uniform(-1000, 1000, (400, 3))
    xyz = np.repeat(places, repeats, axis=0) + rng.normal(0, s, (repeats.sum(), 3))
    groups = np.repeat(np.arange(400), repeats)
    cov, dof = pooled_covariance(xyz, groups)
    assert dof == int(np.sum(repeats - 1))
    np.testing.assert_allclose(np.sqrt(np.diag(cov)), s, rtol=4 / np.sqrt(2 * dof))
    _, rms = group_scatter_mm(xyz, groups)
    assert np.median(rms) == pytest.approx(np.linalg.norm(s), rel=0.15)


def test_expected_rp_is_iso9283s_rp_of_that_scatter():
    """The RP stated for a covariance is the one ISO 9283's own formula gives (pose_figures) over
    30 cycles of that scatter, averaged over many poses (its scatter: the poses' RP's std over
    sqrt(poses)); an isotropic scatter of many cycles tends to 3.616 s."""
    rng = np.random.default_rng(3)
    A = rng.normal(size=(3, 3)) * 0.01
    cov = A @ A.T
    poses = 4000
    attained = rng.multivariate_normal(np.zeros(3), cov, (30, poses))
    _, rp = pose_figures(attained, np.zeros((poses, 3)))
    assert expected_rp(cov, 30) == pytest.approx(rp.mean(), abs=4 * rp.std() / np.sqrt(poses))
    s = 0.02
    assert expected_rp(s**2 * np.eye(3), 2000, draws=400) == pytest.approx(CHI3 * s, rel=0.01)


def test_a_recording_without_repeats_has_no_repeatability():
    with pytest.raises(ValueError, match="no posture is visited twice"):
        pooled_covariance(np.zeros((3, 3)), np.array([-1, -1, -1]))
