"""Circle centres on exact synthetic images, and the perspective bias of a circle's centre."""

import cv2
import numpy as np
import pytest

from calibench.estimators.camera.circles import (
    ellipse_centre_bias,
    find_dark_circle,
    radial_edge_points,
)
from tests.estimators.synthetic import raster_disc

F = 150.0 / 0.0104
K = np.array([[F, 0, 383.5], [0, F, 287.5], [0, 0, 1]])


def _image(R, t, rng, noise=2.0, blur=0.8):
    img = cv2.GaussianBlur(raster_disc(K, R, t, 2.5), (0, 0), blur) + rng.normal(
        0, noise, (576, 768)
    )
    return np.clip(np.rint(img), 0, 255).astype(np.uint8)


def test_fronto_parallel_centres_within_a_hundredth_of_a_pixel():
    rng = np.random.default_rng(10)
    errs = []
    for _ in range(6):
        t = np.array([rng.uniform(-0.4, 0.4), rng.uniform(-0.3, 0.3), 150.0])
        fit = find_dark_circle(
            _image(np.eye(3), t, rng),
        )
        truth = (K @ t)[:2] / t[2]
        errs.append(fit.centre - truth)
        assert fit.radius_px == pytest.approx(2.5 * F / 150, rel=2e-3)
    assert np.sqrt(np.mean(np.sum(np.square(errs), axis=1))) < 0.01


def test_tilted_view_bias_is_predicted_by_the_image_conic():
    """At 0.3 rad tilt the ellipse centre lies about a pixel from the image of the circle's
    centre; the conic's prediction removes it to the detector's noise."""
    rng = np.random.default_rng(11)
    R = cv2.Rodrigues(np.array([0.3, 0.06, 0.0]))[0]
    t = np.array([0.02, -0.03, 150.0])
    fit = find_dark_circle(_image(R, t, rng))
    truth = (K @ t)[:2] / t[2]
    bias = ellipse_centre_bias(K, R, t, 2.5)
    assert np.linalg.norm(bias) > 0.5
    assert np.linalg.norm(fit.centre - truth - bias) < 0.01
    assert np.allclose(ellipse_centre_bias(K, np.eye(3), t, 2.5), 0, atol=1e-12)


def test_no_whole_circle_gives_none():
    rng = np.random.default_rng(12)
    assert find_dark_circle(np.full((576, 768), 200, np.uint8)) is None
    cut = _image(np.eye(3), np.array([3.0, 0.0, 150.0]), rng)  # centre 2900 px off: only an arc
    assert find_dark_circle(cut) is None


def test_a_search_near_the_contour_finds_the_whole_widths_points():
    """The rays sampled between the blob contour's radii alone give the points of a search over
    the whole width, bit for bit: as they stand; with a bright speck inside the disc (the
    samples inside are then all taken); and with the radii where no crossing is (each ray then
    searched over the whole width)."""
    rng = np.random.default_rng(13)
    t = np.array([0.1, -0.05, 150.0])
    img = _image(np.eye(3), t, rng).astype(np.float32)
    centre, r = (K @ t)[:2] / t[2], 2.5 * F / 150
    level = (20 + 230) / 2
    full = radial_edge_points(img, centre, r, level, 720)
    assert len(full) == 720
    got = radial_edge_points(img, centre, r, level, 720, within=(r - 5, r + 5))
    assert np.array_equal(got, full)
    speck = img.copy()
    v, u = int(centre[1]), int(centre[0] + r - 20)
    speck[v - 1 : v + 2, u - 1 : u + 2] = 255.0
    expect = radial_edge_points(speck, centre, r, level, 720)
    assert not np.array_equal(expect, full)  # the speck's ray crosses there first
    got = radial_edge_points(speck, centre, r, level, 720, within=(r - 5, r + 5))
    assert np.array_equal(got, expect)
    got = radial_edge_points(img, centre, r, level, 720, within=(r + 10, r + 12))
    assert np.array_equal(got, full)


def test_medians_in_and_out_are_numpys():
    """The detector's dark and bright levels from histograms: numpy's medians, odd and even
    counts alike (an even count's median halfway between its two middle values)."""
    from calibench.estimators.camera.circles import medians_in_and_out

    rng = np.random.default_rng(3)
    for shape in ((31, 17), (32, 18)):
        img = rng.integers(0, 256, shape).astype(np.uint8)
        mask = np.where(rng.random(shape) < 0.4, 255, 0).astype(np.uint8)
        dark, bright = medians_in_and_out(img, mask)
        assert dark == np.median(img[mask > 0]) and bright == np.median(img[mask == 0])
