"""Extrinsics: the homography closed form (the seed's Eq. 13-18) and PnP against the truth."""

import cv2
import numpy as np
import pytest

from calibench.estimators.camera.pose import (
    board2cam_from_homography,
    board2cam_pnp,
    fit_plane,
    homography,
    mean_rotation,
    undistort_pixels,
)
from calibench.scenes.checkerboard import Chessboard
from tests.estimators.synthetic import project

BOARD = Chessboard(cols=9, rows=6, square_mm=50.0)
K = np.array([[562.45, 0, 319.05], [0, 569.96, 239.31], [0, 0, 1]])
DIST = np.array([-0.12, 0.08, 4e-4, -3e-4, 0.0])


def _pose(rotvec, t):
    return cv2.Rodrigues(np.array(rotvec, float))[0], np.array(t, float)


@pytest.mark.parametrize(
    "rotvec,t", [((0.0, 0.0, 0.01), (-200, -120, 1800)), ((0.4, -0.3, 1.0), (-50, 20, 900))]
)
def test_closed_form_is_exact_on_noiseless_points(rotvec, t):
    R, t = _pose(rotvec, t)
    pix = project(BOARD.corners_mm(), K, R, t, DIST)
    H = homography(BOARD.corners_mm()[:, :2], undistort_pixels(pix, K, DIST))
    R0, t0 = board2cam_from_homography(H, K)
    # exact up to OpenCV's iterative undistortion (about 1e-7 rad)
    np.testing.assert_allclose(R0, R, atol=1e-6)
    np.testing.assert_allclose(t0, t, atol=1e-3)


def test_pnp_within_its_noise_and_closed_form_close_to_it():
    rng = np.random.default_rng(4)
    R, t = _pose((0.05, -0.04, 0.02), (-220, -130, 1780))
    obj = BOARD.corners_mm()
    sigma = 0.05
    gaps, errs = [], []
    for _ in range(50):
        pix = project(obj, K, R, t, DIST) + rng.normal(0, sigma, (len(obj), 2))
        R0, t0 = board2cam_from_homography(
            homography(obj[:, :2], undistort_pixels(pix, K, DIST)), K
        )
        R1, t1 = board2cam_pnp(obj, pix, K, DIST, guess=(R0, t0))
        c = obj.mean(axis=0)
        errs.append((R1 @ c + t1) - (R @ c + t))  # the board centroid, where tilt decouples
        gaps.append(t0 - t1)
    errs = np.array(errs)
    # lateral: sigma * Z / f / sqrt(n) per axis; depth: much weaker (scale of a small board)
    lateral = sigma * 1780 / 566 / np.sqrt(len(obj))
    assert np.all(np.std(errs[:, :2], axis=0) < 1.5 * lateral)
    assert np.all(np.abs(errs[:, :2].mean(axis=0)) < 4 * lateral / np.sqrt(50))
    assert np.max(np.abs(np.array(gaps)[:, :2])) < 3.0  # mm: the closed form is algebraic


def test_mean_rotation_of_rotations_around_one():
    rng = np.random.default_rng(5)
    R, _ = _pose((0.2, 0.1, -0.3), (0, 0, 1))
    noisy = np.array([R @ cv2.Rodrigues(rng.normal(0, 1e-3, 3))[0] for _ in range(400)])
    ang = np.linalg.norm(cv2.Rodrigues(mean_rotation(noisy) @ R.T)[0])
    assert ang < 4 * 1e-3 / np.sqrt(400) * np.sqrt(3)


def test_plane_fit_and_its_slope_covariance():
    """Slopes of the fitted plane scatter as its covariance says (Monte-Carlo, 300 draws)."""
    rng = np.random.default_rng(6)
    xy = rng.uniform(-500, 500, (121, 2))
    slopes, covs = [], []
    for _ in range(300):
        z = 1800 + 2e-3 * xy[:, 0] - 1e-3 * xy[:, 1] + rng.normal(0, 0.2, 121)
        pl = fit_plane(np.c_[xy, z])
        n = pl.normal
        assert n[2] > 0  # by rule, not LAPACK's choice: the largest component positive
        slopes.append(-n[:2] / n[2])
        covs.append(pl.slope_cov)
    slopes = np.array(slopes)
    np.testing.assert_allclose(
        slopes.mean(axis=0), [2e-3, -1e-3], atol=4 * 0.2 / 290 / np.sqrt(121 * 300)
    )
    # the basis is x, then y, projected (the axes least along the normal): slope j is along axis j
    predicted = np.sqrt(np.diag(np.mean(covs, axis=0)))
    np.testing.assert_allclose(np.std(slopes, axis=0), predicted, rtol=0.15)


def test_plane_s_normal_and_basis_are_fixed_by_rule():
    """The same plane from its points in any order and mirrored through its centroid: the same
    normal and in-plane basis (an SVD alone may flip either, differently on another CPU), the
    basis right-handed with the normal and its first vector the x axis projected."""
    rng = np.random.default_rng(7)
    xy = rng.uniform(-500, 500, (60, 2))
    pts = np.c_[xy, 1800 + 3e-3 * xy[:, 0] + 2e-3 * xy[:, 1] + rng.normal(0, 0.2, 60)]
    ref = fit_plane(pts)
    for other in (pts[::-1], pts[rng.permutation(60)], 2 * pts.mean(axis=0) - pts):
        pl = fit_plane(other)
        np.testing.assert_allclose(pl.normal, ref.normal, atol=1e-12)
        np.testing.assert_allclose(pl.basis, ref.basis, atol=1e-12)
    B = ref.basis
    np.testing.assert_allclose(B.T @ B, np.eye(2), atol=1e-15)
    np.testing.assert_allclose(np.cross(B[:, 0], B[:, 1]), ref.normal, atol=1e-15)
    x_on_plane = np.array([1.0, 0, 0]) - ref.normal * ref.normal[0]
    np.testing.assert_allclose(B[:, 0], x_on_plane / np.linalg.norm(x_on_plane), atol=1e-15)


def test_ray_plane_intersection_removes_depth_noise():
    pl = fit_plane(np.array([[0, 0, 1000.0], [100, 0, 1000], [0, 100, 1000], [100, 100, 1000]]))
    p = np.array([[30.0, 40.0, 1000.0]])
    np.testing.assert_allclose(pl.intersect_rays(p * 1.01), p, atol=1e-9)


def test_pose_sensitivity_is_what_pnp_does_when_the_intrinsics_move():
    """The implicit-function Jacobian d(rvec, t) / d(fx, fy, cx, cy, k1, k2, p1, p2) against
    central differences of solvePnP itself (re-solved at each perturbed intrinsics), on a tilted
    board's exact projections plus 0.02 px noise: within 2 % of each column's largest entry."""
    import cv2

    from calibench.estimators.camera.pose import board2cam_pnp, pose_sensitivity

    names = ("fx", "fy", "cx", "cy", "k1", "k2", "p1", "p2")
    K = np.array([[900.0, 0, 330], [0, 905.0, 245], [0, 0, 1]])
    dist = np.array([-0.2, 0.08, 1e-3, -5e-4, 0.0])
    obj = np.c_[np.mgrid[0:9, 0:6].T.reshape(-1, 2) * 25.0, np.zeros(54)]
    rvec, tvec = np.array([0.3, -0.2, 0.1]), np.array([-100.0, -60.0, 700.0])
    px = cv2.projectPoints(obj, rvec, tvec, K, dist)[0].reshape(-1, 2)
    px += np.random.default_rng(4).normal(0, 0.02, px.shape)
    R, t = board2cam_pnp(obj, px, K, dist, guess=(cv2.Rodrigues(rvec)[0], tvec))
    S = pose_sensitivity(obj, R, t, K, dist, names)
    steps = {
        "fx": 0.5,
        "fy": 0.5,
        "cx": 0.5,
        "cy": 0.5,
        "k1": 1e-3,
        "k2": 1e-3,
        "p1": 1e-5,
        "p2": 1e-5,
    }
    for j, n in enumerate(names):
        out = []
        for sgn in (1, -1):
            Kp, dp = K.copy(), dist.copy()
            if n in ("fx", "fy", "cx", "cy"):
                Kp[{"fx": (0, 0), "fy": (1, 1), "cx": (0, 2), "cy": (1, 2)}[n]] += sgn * steps[n]
            else:
                dp[{"k1": 0, "k2": 1, "p1": 2, "p2": 3}[n]] += sgn * steps[n]
            Rp, tp = board2cam_pnp(obj, px, Kp, dp, guess=(R, t))
            out.append(np.r_[cv2.Rodrigues(Rp)[0].ravel(), tp])
        fd = (out[0] - out[1]) / (2 * steps[n])
        np.testing.assert_allclose(S[:, j], fd, atol=0.02 * np.abs(fd).max(), err_msg=n)


def test_refined_poses_are_the_reprojection_minimum():
    """Several views refined at once land where OpenCV's Levenberg-Marquardt lands when it is
    run to convergence (solvePnPRefineLM at 1e-15, restarted from its own result: one run stops
    about 1e-7 rad short), from a start a few mm and mrad off, a corner left out (NaN) of one
    view."""
    from calibench.estimators.camera.pose import board2cam_refine

    rng = np.random.default_rng(7)
    obj = BOARD.corners_mm()
    truth = [
        _pose((0.05, -0.04, 0.02), (-220, -130, 1780)),
        _pose((0.3, 0.2, -0.4), (-100, -50, 1500)),
    ]
    pix = np.stack(
        [project(obj, K, R, t, DIST) + rng.normal(0, 0.05, (len(obj), 2)) for R, t in truth]
    )
    pix[1, 5] = np.nan
    R0 = np.stack([cv2.Rodrigues(np.array([3e-3, -2e-3, 1e-3]))[0] @ R for R, _ in truth])
    t0 = np.stack([t + [2.0, -3.0, 5.0] for _, t in truth])
    R1, t1 = board2cam_refine(obj, pix, K, DIST, R0, t0)
    crit = (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 200, 1e-15)
    for v in range(2):
        kept = np.isfinite(pix[v]).all(axis=1)
        rvec, tvec = cv2.Rodrigues(R0[v])[0], t0[v].reshape(3, 1).copy()
        for _ in range(3):
            rvec, tvec = cv2.solvePnPRefineLM(
                obj[kept], pix[v][kept], K, DIST, rvec, tvec, criteria=crit
            )
        np.testing.assert_allclose(cv2.Rodrigues(R1[v])[0].ravel(), rvec.ravel(), atol=2e-9)
        np.testing.assert_allclose(t1[v], tvec.ravel(), atol=2e-6)  # mm, at 1.5-1.8 m
