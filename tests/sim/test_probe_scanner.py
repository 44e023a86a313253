"""The probe scanner's ray cast limited to the walls a ray can reach finds what a cast against
every wall finds, to the last bit."""

import numpy as np
import pytest

from calibench.scenarios.probe_scanner.scenario import ProbeScannerConfig
from calibench.sim.probe_scanner import (
    N_SECTORS,
    ProbeScannerSim,
    ProbeScannerTruth,
    box_corners_xy,
    ray_sectors,
)


def _slab_hits(origin, direction, pos, mat, size):
    """Which boxes a ray meets at s >= 0 (the slab test in each box's frame, independent of
    MuJoCo and of ray_sectors), (n,) bool."""
    o = np.einsum("nji,nj->ni", mat, origin - pos)  # the ray in each box's frame
    d = np.einsum("nji,j->ni", mat, direction)
    with np.errstate(divide="ignore", invalid="ignore"):
        t1, t2 = (-size - o) / d, (size - o) / d
    lo = np.where(
        np.abs(d) > 1e-15, np.minimum(t1, t2), np.where(np.abs(o) <= size, -np.inf, np.inf)
    )
    hi = np.where(
        np.abs(d) > 1e-15, np.maximum(t1, t2), np.where(np.abs(o) <= size, np.inf, -np.inf)
    )
    enter, leave = lo.max(axis=1), hi.min(axis=1)
    return (enter <= leave) & (leave >= 0)


@pytest.mark.parametrize("seed", [3, 5, 8])
def test_every_box_a_ray_meets_is_in_its_sectors_set(seed):
    """Random boxes around an axis; one ray (from Q0, |Q0| = 5, along u0) turned about it, as
    the rail turns with the table: each box the ray meets at 3,000 random table angles is among
    the candidates of its direction's sector."""
    rng = np.random.default_rng(seed)
    n = 400
    radius, angle = rng.uniform(9.0, 40.0, n), rng.uniform(-np.pi, np.pi, n)
    pos = np.c_[radius * np.cos(angle), radius * np.sin(angle), np.zeros(n)]
    yaw = rng.uniform(-np.pi, np.pi, n)
    mat = np.zeros((n, 3, 3))
    mat[:, 0, 0], mat[:, 0, 1], mat[:, 1, 0], mat[:, 1, 1] = (
        np.cos(yaw),
        -np.sin(yaw),
        np.sin(yaw),
        np.cos(yaw),
    )
    mat[:, 2, 2] = 1.0
    size = np.c_[rng.uniform(0.2, 12.0, n), rng.uniform(0.2, 2.0, n), np.full(n, 4.0)]
    a, phi = rng.uniform(-np.pi, np.pi, 2)
    q0, u0 = 5.0 * np.array([np.cos(a), np.sin(a)]), np.array([np.cos(phi), np.sin(phi)])
    masks = ray_sectors(box_corners_xy(pos, mat, size), q0, u0)
    missed = 0
    for theta in rng.uniform(-np.pi, np.pi, 3000):
        c, s = np.cos(theta), np.sin(theta)
        R = np.array([[c, -s], [s, c]])
        origin, direction = np.r_[R @ q0, 0.0], np.r_[R @ u0, 0.0]
        k = (
            int(
                np.floor((np.arctan2(direction[1], direction[0]) + np.pi) / (2 * np.pi) * N_SECTORS)
            )
            % N_SECTORS
        )
        missed += int(np.sum(_slab_hits(origin, direction, pos, mat, size) & ~masks[k]))
    assert missed == 0
    assert np.mean([m.mean() for m in masks]) < 0.3  # and the sets are a real cut


def _cast_in_the_whole_twin(sim, part, theta):
    """The rays exact_rho casts, each against every geom of the whole twin (plain mj_ray)."""
    import mujoco
    from scipy.spatial.transform import Rotation

    from calibench.scenes.probe_scanner import LENS_GROUP, PLATE_GROUP

    sim.turn_to(0.0)
    j = sim.model.joint("theta").id
    c, axis = sim.data.xanchor[j].copy(), sim.data.xaxis[j].copy()
    q0 = sim.data.site_xpos[sim._q] - c
    u0 = sim.data.site_xpos[sim._dir] - sim.data.site_xpos[sim._q]
    R = Rotation.from_rotvec(np.outer(theta, axis)).as_matrix()
    q, u = c + R @ q0, R @ (u0 / np.linalg.norm(u0))
    group = np.zeros(6, np.uint8)
    group[PLATE_GROUP if part == "plate" else LENS_GROUP] = 1
    gid = np.zeros(1, np.int32)
    return (
        np.array(
            [mujoco.mj_ray(sim.model, sim.data, qi, ui, group, 1, -1, gid) for qi, ui in zip(q, u)]
        )
        * 1000
    )


@pytest.mark.parametrize(
    "truth",
    [
        ProbeScannerTruth(),
        ProbeScannerTruth(d_mm=10.5, dL_mm=1.0, alpha0_rad=-0.6, plate_centre_mm=(0.9, 0.5)),
    ],
)
def test_limited_cast_equals_the_cast_in_the_whole_twin(truth):
    """The part's own model, the sectors' hidden walls: the same distances, bit for bit."""
    sim = ProbeScannerSim(ProbeScannerConfig().geometry, truth)
    theta = np.random.default_rng(4).uniform(0, 2 * np.pi, 2000)
    for part in ("plate", "lens"):
        np.testing.assert_array_equal(
            sim.exact_rho(part, theta), _cast_in_the_whole_twin(sim, part, theta)
        )
