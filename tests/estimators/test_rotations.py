"""The rotation helpers against closed forms, at the angles where hand-written formulas break:
tiny rotations (an arccos of the trace keeps half the digits) and rotations near pi."""

import numpy as np
import pytest

from calibench.estimators.rotations import (
    matrix_to_rotvec,
    rigid_transform,
    rotvec_to_matrix,
    rotvecs_to_matrices,
    skew,
)


def _rot_z(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


@pytest.mark.parametrize("angle", [1e-12, 1e-9, 1e-7, 1e-3, 1.0, 3.0, np.pi - 1e-6, np.pi - 1e-9])
def test_matrix_to_rotvec_is_exact_at_every_angle(angle):
    """Rotations about z by ``angle``: the rotation vector is (0, 0, angle), to a relative 1e-9
    (the closed form R_z is exact, so any error is the conversion's)."""
    w = matrix_to_rotvec(_rot_z(angle))
    assert w[:2] == pytest.approx([0, 0], abs=1e-12)
    assert w[2] == pytest.approx(angle, rel=1e-9, abs=1e-15)


def test_rotvec_round_trip_and_batch_agree():
    rng = np.random.default_rng(0)
    axes = rng.normal(size=(200, 3))
    axes /= np.linalg.norm(axes, axis=1, keepdims=True)
    w = axes * rng.uniform(1e-10, np.pi - 1e-6, (200, 1))
    Rs = rotvecs_to_matrices(w)
    for wi, Ri in zip(w, Rs):
        np.testing.assert_allclose(rotvec_to_matrix(wi), Ri, atol=1e-15)
        np.testing.assert_allclose(Ri @ Ri.T, np.eye(3), atol=1e-14)
        np.testing.assert_allclose(matrix_to_rotvec(Ri), wi, rtol=1e-8, atol=1e-14)
    # a small rotation is I + skew(w) to first order
    small = 1e-8 * axes[0]
    np.testing.assert_allclose(rotvec_to_matrix(small), np.eye(3) + skew(small), atol=1e-16)


@pytest.mark.parametrize(
    "angle", [0.0, 1e-12, 1e-9, 1e-8, 1.1e-8, 1e-7, 1e-3, 1.0, 3.0, np.pi - 1e-9]
)
def test_rotvecs_to_matrices_equal_scipy_s_at_every_angle(angle):
    """Rodrigues' formula written with half angles against scipy's quaternion route, to 1e-15 (a
    few rounding units of 1), across the switch to the series at 1e-8 rad, over random axes; the
    scalar forms equal the stacked one, and the inverse equals scipy's."""
    from scipy.spatial.transform import Rotation

    axes = np.random.default_rng(1).normal(size=(50, 3))
    w = angle * axes / np.linalg.norm(axes, axis=1, keepdims=True)
    np.testing.assert_allclose(
        rotvecs_to_matrices(w), Rotation.from_rotvec(w).as_matrix(), rtol=0, atol=1e-15
    )
    np.testing.assert_array_equal(
        np.array([rotvec_to_matrix(v) for v in w]), rotvecs_to_matrices(w)
    )
    np.testing.assert_array_equal(
        rotvec_to_matrix(w.reshape(5, 10, 3)), rotvecs_to_matrices(w).reshape(5, 10, 3, 3)
    )
    # and back, as scipy's quaternion route does it (each of Shepperd's four branches is taken)
    back = np.array([matrix_to_rotvec(R) for R in rotvecs_to_matrices(w)])
    np.testing.assert_allclose(
        back, Rotation.from_matrix(rotvecs_to_matrices(w)).as_rotvec(), rtol=0, atol=2e-15
    )
    np.testing.assert_array_equal(
        matrix_to_rotvec(rotvecs_to_matrices(w).reshape(5, 10, 3, 3)), back.reshape(5, 10, 3)
    )


def test_rigid_transform_recovers_a_known_pose():
    rng = np.random.default_rng(1)
    src = rng.normal(size=(50, 3)) * 100
    R, t = rotvec_to_matrix([0.3, -1.2, 2.5]), np.array([10.0, -4.0, 7.0])
    R_est, t_est = rigid_transform(src, src @ R.T + t)
    np.testing.assert_allclose(R_est, R, atol=1e-12)
    np.testing.assert_allclose(t_est, t, atol=1e-9)
    # a stack of sets, one fit each; a mirror image still gives a rotation, not a reflection
    R2 = rotvec_to_matrix([-2.0, 0.4, 0.1])
    Rs, ts = rigid_transform(src, np.stack([src @ R.T + t, src @ R2.T]))
    np.testing.assert_allclose(Rs, [R, R2], atol=1e-12)
    np.testing.assert_allclose(ts, [t, np.zeros(3)], atol=1e-9)
    assert np.linalg.det(rigid_transform(src, src * [-1.0, 1.0, 1.0])[0]) == pytest.approx(1.0)


def test_scipy_order_is_scipys_to_the_bit():
    """The camera's rotations are scipy's arithmetic without its import: the same bits at every
    angle, the small-angle series (below 1e-3 rad) and near pi included."""
    from scipy.spatial.transform import Rotation

    from calibench.estimators.rotations import (
        matrices_to_rotvecs_scipy,
        rotvecs_to_matrices_scipy,
    )

    rng = np.random.default_rng(7)
    for top in (1e-7, 1e-3, 0.3, 3.14159):
        u = rng.normal(size=(500, 3))
        w = u / np.linalg.norm(u, axis=1, keepdims=True) * rng.uniform(0, top, (500, 1))
        R = Rotation.from_rotvec(w).as_matrix()
        np.testing.assert_array_equal(rotvecs_to_matrices_scipy(w), R)
        np.testing.assert_array_equal(
            matrices_to_rotvecs_scipy(R), Rotation.from_matrix(R).as_rotvec()
        )
    skewed = R + 1e-6  # not orthonormal: scipy projects it first, and so does this
    np.testing.assert_array_equal(
        matrices_to_rotvecs_scipy(skewed), Rotation.from_matrix(skewed).as_rotvec()
    )
