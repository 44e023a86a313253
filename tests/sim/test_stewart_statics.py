"""The Stewart twin's statics (MuJoCo's inverse dynamics and constraint Jacobian) against the
platform's Newton-Euler balance written independently: with massless legs, the six axial forces
along the legs' axes carry the platform's weight and its payload, forces and moments."""

import numpy as np

from calibench.estimators.rotations import rotvec_to_matrix
from calibench.scenes.stewart import StewartGeometry
from calibench.sim.stewart import StewartSim, StewartTruth


def _balance(sim, R, t, load_n):
    m = sim.model
    P = sim.r @ R.T + t
    u = P - sim.B
    u /= np.linalg.norm(u, axis=1)[:, None]
    body = m.body("platform").id
    W = np.r_[0.0, 0.0, -(m.body_mass[body] * 9.81 + load_n)]
    com = (
        sim.data.xipos[body] * 1000 - t
    )  # the payload hangs at the origin, the weight at the centre of mass
    moment = np.cross(com, np.r_[0.0, 0.0, -m.body_mass[body] * 9.81])
    A = np.vstack([u.T, np.cross(sim.r @ R.T, u).T])
    return np.linalg.solve(A, -np.r_[W, moment])


def test_leg_forces_balance_the_platform():
    sim = StewartSim(StewartGeometry(), StewartTruth(), np.random.default_rng(4))
    m = sim.model
    for i in range(6):
        for name in (f"leg{i}", f"leg{i}_rod"):
            m.body_mass[m.body(name).id] = 1e-12
            m.body_inertia[m.body(name).id] = 1e-12
    rng = np.random.default_rng(5)
    for _ in range(5):
        R = rotvec_to_matrix(rng.uniform(-0.15, 0.15, 3))
        t = np.r_[rng.uniform(-150, 150, 2), 750 + rng.uniform(-150, 150)]
        load = rng.uniform(0, 2000)
        f = sim.leg_forces_n(R, t, load)
        assert np.allclose(f, _balance(sim, R, t, load), atol=1e-6)  # N, against forces of ~100 N


def test_legs_own_weight_adds_to_their_forces():
    """With the legs' masses the forces differ from the platform-only balance by a few newtons
    (a 3 kg leg leans on both its hinges): the statics see the whole mechanism."""
    sim = StewartSim(StewartGeometry(), StewartTruth(), np.random.default_rng(4))
    R, t = np.eye(3), np.array([0.0, 0.0, 750.0])
    f = sim.leg_forces_n(R, t)
    extra = f - _balance(sim, R, t, 0.0)
    assert np.all(np.abs(extra) > 1.0) and np.all(np.abs(extra) < 3 * 9.81)
