"""A new session of a calibrated arm: its own terms fitted on a few of its rows, held to the
machine's values by the session prior."""

import numpy as np

from calibench.estimators.arm import session
from calibench.estimators.arm.point import PointProblem
from calibench.estimators.arm.terms import AngleTerm
from calibench.estimators.identification.solver import identify_identifiable
from calibench.estimators.rotations import rotvec_to_matrix
from calibench.scenarios.arm_cmm.arms import chain_of
from calibench.sim.arm_cmm import ArmSim, ArmTruth


def test_session_prior_holds_the_corrections_few_registration_rows_fit(monkeypatch):
    """A UR10 (MuJoCo) whose joints 1 to 3 carry a gear harmonic each, calibrated on 400
    postures at 0.2 mm (the UR10 tracker series' scatter); new sessions move each coefficient by
    50 urad (1 sigma) and are registered on 6 rows (18 values for 6 corrections and the frame's
    6). Unregularised, the corrections run to about a milliradian (the rows' noise, nearly
    interpolated); with the prior they stay within 3 of its std, and the 54 rows scored are no
    worse in any session, within twice the noise."""
    sim = ArmSim("ur10", ArmTruth())
    rng = np.random.default_rng(5)
    noise, m = 0.2, 6
    terms = [
        AngleTerm(j, "harmonic", harmonic=h, label="transmission")
        for j, h in ((1, 7.3), (2, 17.3), (3, 11.6))
    ]
    machine = rng.normal(0, 200e-6, 2 * len(terms))

    def points(q, c):
        link = q.copy()
        for i, t in enumerate(terms):
            link[:, t.joint - 1] -= t.functions(q[:, t.joint - 1]) @ c[2 * i : 2 * i + 2]
        return sim.point_mm(link)

    q = sim.random_postures(400, rng)
    y = points(q, machine) + rng.normal(0, noise, (len(q), 3))
    problem = PointProblem(
        chain_of(sim.arm), q, y, np.zeros(len(q), int), np.full_like(y, noise), angle_terms=terms
    )
    fit = identify_identifiable(problem)
    assert fit.converged
    prior, largest_free = session.SESSION_PRIOR_RAD, 0.0
    for _ in range(6):
        q_new = sim.random_postures(60, rng)
        shift = rng.normal(0, 50e-6, len(machine))
        R, t = rotvec_to_matrix(rng.normal(0, 0.3, 3)), rng.normal(0, 500, 3)
        y_new = points(q_new, machine + shift) @ R.T + t + rng.normal(0, noise, (60, 3))
        scored = {}
        for std in (np.inf, prior):  # inf: the prior's rows weigh nothing
            monkeypatch.setattr(session, "SESSION_PRIOR_RAD", std)
            own, model = session.register_session(problem, fit.state, q_new, y_new, np.arange(m))
            assert len(own.coef) == 2 * len(terms) and own.converged
            scored[std] = np.sqrt(np.mean((model[m:] - y_new[m:]) ** 2))
            if std == prior:
                assert np.abs(own.coef).max() < 3 * prior
            else:
                largest_free = max(largest_free, np.abs(own.coef).max())
        monkeypatch.undo()
        assert scored[prior] <= scored[np.inf] and scored[prior] < 2 * noise, scored
    assert largest_free > 5 * prior


def test_a_sessions_shift_is_recovered_not_pulled_to_the_machines_value():
    """A UR10 (MuJoCo) whose joints 1 to 3 carry a gear harmonic each and whose joint 2 a table
    of three bands, calibrated on 600 postures at 30 um. Twelve new sessions, each registered
    on 40 rows, move every harmonic coefficient by 50 urad (a random sign) and joint 2's zero by
    50 urad (every band of its table alike: an offset each power-up sets), half the prior's std:
    what the prior is there to let through. Each correction is then determined by its rows to
    about 12 urad, so the prior's pull toward the machine's value is about 1 % of the shift
    (0.7 urad); a prior ten times tighter (1e-5) pulls it half-way back (about 25 urad). The
    mean pull over the sessions, measured against the planted shift, must be within 4 standard
    errors of zero (the standard error from the sessions' own scatter)."""
    sim = ArmSim("ur10", ArmTruth())
    rng = np.random.default_rng(7)
    noise, m, shift_rad = 0.03, 40, 50e-6
    terms = [
        AngleTerm(j, "harmonic", harmonic=h, label="transmission")
        for j, h in ((1, 7.3), (2, 17.3), (3, 11.6))
    ]
    edges = (-np.inf, np.radians(-60.0), np.radians(60.0), np.inf)
    terms.append(AngleTerm(2, "table", edges_rad=edges, label="table"))
    sizes = [len(t.names) for t in terms]
    machine = rng.normal(0, 200e-6, sum(sizes))

    def points(q, c):
        """The twin's tool points with the links at the readings less the terms' errors."""
        link, at = q.copy(), np.cumsum([0] + sizes)
        for i, t in enumerate(terms):
            link[:, t.joint - 1] -= t.functions(q[:, t.joint - 1]) @ c[at[i] : at[i + 1]]
        return sim.point_mm(link)

    q = sim.random_postures(600, rng)
    y = points(q, machine) + rng.normal(0, noise, (len(q), 3))
    problem = PointProblem(
        chain_of(sim.arm), q, y, np.zeros(len(q), int), np.full_like(y, noise), angle_terms=terms
    )
    fit = identify_identifiable(problem)
    assert fit.converged
    pulls = []
    for _ in range(12):
        shift = shift_rad * rng.choice([-1.0, 1.0], len(machine))
        shift[-sizes[-1] :] = shift[-1]  # the table's bands move together: joint 2's zero
        q_new = sim.random_postures(m, rng)
        R, t = rotvec_to_matrix(rng.normal(0, 0.3, 3)), rng.normal(0, 500, 3)
        y_new = points(q_new, machine + shift) @ R.T + t + rng.normal(0, noise, (m, 3))
        own, _ = session.register_session(problem, fit.state, q_new, y_new, np.arange(m))
        assert own.converged and len(own.coef) == len(shift)
        # how far each correction fell short of its shift, toward the machine's value (zero)
        pulls.append(np.mean((shift - own.coef) * np.sign(shift)))
    pull, stderr = np.mean(pulls), np.std(pulls, ddof=1) / np.sqrt(len(pulls))
    assert abs(pull) < 4 * stderr, (pull, stderr, pulls)
