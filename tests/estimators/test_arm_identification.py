"""Identification of the arm's errors: Jacobians, identifiability, recovery and honest std.

Data come from the MuJoCo arm (sim), whose as-built frames carry the injected errors: an
implementation independent of the estimator's kinematics.
"""

import numpy as np
import pytest

from calibench.estimators.arm_identification import (ConeProblem, TrackerProblem, identifiable_basis, identify,
                                           identify_identifiable, observability_index, parameter_scales,
                                           select_postures)
from calibench.estimators.arm_kinematics import point_in_link7
from calibench.scenarios.arm_cmm import chain_of, tracker_problem
from calibench.scenes.arm_cmm import ArmGeometry
from calibench.sim.arm_cmm import TABLE1_DELTA, ArmSim, ArmTruth


@pytest.fixture(scope="module")
def arm():
    g = ArmGeometry()
    return ArmSim(g, ArmTruth()), chain_of(g)


def test_mujoco_arm_is_the_estimators_arm(arm):
    sim, chain = arm
    q = sim.random_postures(30, np.random.default_rng(0))
    np.testing.assert_allclose(sim.probe_mm(q), point_in_link7(chain, q, np.array(TABLE1_DELTA)), atol=1e-9)


def test_tracker_jacobian_matches_differences(arm):
    sim, chain = arm
    rng = np.random.default_rng(1)
    q = sim.random_postures(8, rng)
    p = tracker_problem(sim, chain, q, q, rng)
    s = p.start()
    s.delta = np.array(TABLE1_DELTA) * 0.5
    J = p.jacobian(s)
    for k in range(34):
        h = 1e-7 if (k < 25 and PARAM_IS_ANGLE[k]) or 25 <= k < 28 else 1e-5
        e = np.zeros(34)
        e[k] = h
        fd = (p.residuals(p.update(s, e)) - p.residuals(p.update(s, -e))) / (2 * h)
        np.testing.assert_allclose(J[:, k], fd, rtol=1e-4, atol=1e-3 * np.abs(J[:, k]).max())


PARAM_IS_ANGLE = [n.startswith(("dalpha", "dtheta")) for n in
                  __import__("calibench.estimators.arm_kinematics", fromlist=["PARAM_NAMES"]).PARAM_NAMES]


def test_dropped_parameters_are_named_with_their_partners(arm):
    sim, chain = arm
    q = sim.random_postures(50, np.random.default_rng(2))
    basis = identifiable_basis(tracker_problem(sim, chain, q, q, None))
    assert "tracker_rz" in basis.dropped["dtheta1"]  # a turn of the base is a turn of the tracker
    assert "tracker_z" in basis.dropped["dd1"]
    assert {"reflector_x", "reflector_y", "reflector_z"} <= set(basis.dropped)  # the stylus stands in


def test_identification_recovers_the_effective_truth_with_honest_std(arm):
    sim, chain = arm
    z = []
    for seed in range(12):
        rng = np.random.default_rng(100 + seed)
        q = sim.random_postures(50, rng)
        noisy = tracker_problem(sim, chain, q, sim.encoders(q, rng), rng)
        ident = identify_identifiable(noisy)
        exact_problem = tracker_problem(sim, chain, q, q, None)
        exact_problem.R_ref = noisy.R_ref
        exact = identify(exact_problem, ident.basis)
        z += [(ident.estimate[n] - exact.estimate[n]) / ident.std[n] for n in ident.estimate]
        assert ident.rms == pytest.approx(1.0, abs=0.25)  # the noise model is the truth's
    z = np.array(z)
    assert np.all(np.abs(z) < 5.5)
    assert 0.6 < np.sqrt(np.mean(z**2)) < 1.5


def test_cone_problem_drops_what_free_cones_absorb(arm):
    sim, chain = arm
    rng = np.random.default_rng(3)
    truth = sim.truth
    q = np.vstack([sim.postures_in_cone(np.asarray(c), 30, rng) for c in (truth.cone_a_mm, truth.cone_b_mm)])
    p = ConeProblem(chain, sim.encoders(q, rng), np.repeat([0, 1], 30), 0.01, truth.bar_length_mm, 0.001)
    ident = identify_identifiable(p)
    assert {"dtheta1", "dd1"} <= set(ident.basis.dropped)


def test_chosen_postures_are_more_observable_than_random_ones(arm):
    sim, chain = arm
    cand = sim.random_postures(300, np.random.default_rng(4))
    plan = tracker_problem(sim, chain, cand, cand, None)
    basis = identifiable_basis(plan)
    J = plan.jacobian(plan.start())[:, basis.kept] * parameter_scales([plan.names[k] for k in basis.kept])
    blocks = J.reshape(len(cand), 3, -1)
    chosen = select_postures(blocks, 30)
    assert len(set(chosen)) == 30
    o_chosen = observability_index(blocks[chosen].reshape(-1, blocks.shape[2]))
    o_random = observability_index(blocks[:30].reshape(-1, blocks.shape[2]))
    assert o_chosen > 1.1 * o_random
