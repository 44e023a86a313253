"""The camera model's projection against OpenCV's projectPoints, and its analytic Jacobians
against central differences (mink's habit)."""

import cv2
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from calibench.estimators.camera.projection import INTRINSICS, project

INTR = np.array([612.0, 607.0, 321.0, 238.0, -0.21, 0.09, 8e-4, -5e-4, 0.03])
OBJ = np.c_[np.mgrid[0:9, 0:6].T.reshape(-1, 2) * 30.0, np.zeros(54)]
ROTVECS = np.array([[0.3, -0.2, 0.1], [-0.4, 0.35, 1.2]])
TRANS = np.array([[-110.0, -70.0, 650.0], [20.0, -90.0, 820.0]])


def _views():
    return Rotation.from_rotvec(ROTVECS).as_matrix(), TRANS.copy()


def test_pixels_are_opencvs():
    R, t = _views()
    uv = project(INTR, R, t, OBJ).uv
    K = np.array([[INTR[0], 0, INTR[2]], [0, INTR[1], INTR[3]], [0, 0, 1]])
    for v in range(2):
        ref = cv2.projectPoints(OBJ, ROTVECS[v], TRANS[v], K, INTR[4:])[0].reshape(-1, 2)
        np.testing.assert_allclose(uv[v], ref, atol=1e-9)


@pytest.mark.parametrize("k", range(9))
def test_intrinsic_jacobian_is_the_derivative(k):
    R, t = _views()
    h = 1e-4 * max(abs(INTR[k]), 1e-2)
    up, dn = INTR.copy(), INTR.copy()
    up[k] += h
    dn[k] -= h
    fd = (project(up, R, t, OBJ).uv - project(dn, R, t, OBJ).uv) / (2 * h)
    an = project(INTR, R, t, OBJ).d_intrinsics[..., k]
    np.testing.assert_allclose(an, fd, atol=1e-6 * np.abs(fd).max() + 1e-9, err_msg=INTRINSICS[k])


@pytest.mark.parametrize("k", range(6))
def test_pose_jacobian_is_the_derivative_of_a_left_perturbation(k):
    R, t = _views()
    h = 1e-6 if k < 3 else 1e-3
    out = []
    for s in (h, -h):
        d = np.zeros(6)
        d[k] = s
        Rp = Rotation.from_rotvec(d[:3]).as_matrix() @ R
        out.append(project(INTR, Rp, t + d[3:], OBJ).uv)
    fd = (out[0] - out[1]) / (2 * h)
    an = project(INTR, R, t, OBJ).d_pose[..., k]
    np.testing.assert_allclose(an, fd, atol=1e-6 * np.abs(fd).max())
