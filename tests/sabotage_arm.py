"""Issue 63's faults, the arm's, for ``tests/sabotage.py``: a left-out session's rows and prior,
a coupling applied transposed, a transmission's units, a compliance below zero, the drives'
directions over the fitted rows only. Each entry of :data:`ARM_FAULTS` is a ``Fault``'s
(description, apply, targets)."""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Callable

import numpy as np
import pytest

from tests.sabotage_faults import replace

LOSO_ROWS = (
    "tests/scenarios/test_arm_left_out_rows.py::"
    "test_a_left_out_sessions_fitted_rows_are_never_its_scored_rows"
)
CABLES = "tests/scenarios/test_arm_cables_asymmetric.py"
UNITS = "tests/scenarios/test_arm_units.py"


def left_out_session_fitted_on_scored_rows(said: bool) -> Callable[[pytest.MonkeyPatch], None]:
    """A fault fitting a new session's frame and own terms on the rows that score it (what
    ``register_on_scored`` does for the floor) while its score is still called held out;
    ``said``: its report names those rows as fitted (else it names the registration rows, so
    only what the fit touched shows it)."""

    def apply(mp: pytest.MonkeyPatch) -> None:
        from calibench.scenarios.arm_cmm import scoring

        real = scoring.register_new_frame

        @functools.wraps(real)
        def register(problem, state, path, rec, usable, register_on_scored):
            nf = real(problem, state, path, rec, usable, True)
            if said or register_on_scored:
                return nf
            return dataclasses.replace(nf, fitted_on=nf.register_rows)

        replace(mp, "calibench.scenarios.arm_cmm.scoring", "register_new_frame", register)

    return apply


def session_prior_10x_tight(mp: pytest.MonkeyPatch) -> None:
    """A new session's corrections to the shared terms held to the machine's values by a prior
    ten times too tight (1e-5 rad, not 1e-4)."""
    from calibench.estimators.arm import session

    tight = session.SESSION_PRIOR_RAD / 10
    replace(mp, "calibench.estimators.arm.session", "SESSION_PRIOR_RAD", tight)


def arm_cable_coupling_transposed(mp: pytest.MonkeyPatch) -> None:
    """The estimators' arm model built with the coupling transposed: each motor's cable stretches
    under the torque its row of the coupling carries back, and its stretch turns the joints of
    that row (its column, in both, is the physics)."""
    from calibench.estimators.arm import point

    real = point.PointProblem.__init__

    @functools.wraps(real)
    def init(self, chain, *a, **k):
        if chain.coupling is None:
            return real(self, chain, *a, **k)
        transposed = dataclasses.replace(chain, coupling=np.asarray(chain.coupling, float).T)
        real(self, transposed, *a, **k)
        self.chain = chain  # the problem's arm as given: only the cables' columns transposed

    mp.setattr(point.PointProblem, "__init__", init)


def twin_cable_coupling_transposed(mp: pytest.MonkeyPatch) -> None:
    """The twin's cables with the coupling transposed in its statics (frictionless cables): the
    links settle by coupling.T diag(c) coupling tau, not coupling diag(c) coupling.T tau
    (MuJoCo's tendons untouched)."""
    from calibench.sim.arm_cmm import ArmSim

    real = ArmSim.__init__

    @functools.wraps(real)
    def init(self, *a, **k):
        real(self, *a, **k)
        C, c = self.coupling, self.cable_compliance
        self.compliance = self.compliance - (C * c) @ C.T + (C.T * c) @ C

    mp.setattr(ArmSim, "__init__", init)


def cable_scale_in_motor_units(mp: pytest.MonkeyPatch) -> None:
    """A cable's typical size taken at the motor in the coupling's unit (10 urad / N m whatever
    its column), not at its joints: which cables the data determine then depends on the unit."""
    from calibench.estimators.arm import point
    from calibench.estimators.arm.kinematics import ArmParameters

    mp.setattr(point.PointProblem, "scales", ArmParameters.scales)


def compliance_below_zero_used(mp: pytest.MonkeyPatch) -> None:
    """fit's compliances solved without their bound: one fitted below zero is used."""
    from calibench.estimators.arm import calibration

    def unbounded(problem, basis, state):
        return calibration.identify(problem, basis, state), basis, {}

    mp.setattr(calibration, "identify_physical", unbounded)


def compliance_implausible_ignored(mp: pytest.MonkeyPatch) -> None:
    """discover's candidates never implausible: a compliance fitted below zero is named."""
    from calibench.estimators.discovery.arm_compliance import JointCompliance

    mp.setattr(JointCompliance, "implausible", lambda self, coef, cov: "")


def directions_over_fitted_rows(mp: pytest.MonkeyPatch) -> None:
    """The drives' directions of last motion taken over the fitted rows alone: a held-out row's
    move is lost."""
    replace(mp, "calibench.scenarios.arm_cmm.training", "stacked_directions", lambda *a: None)


ARM_FAULTS: dict[str, tuple[str, Callable[[pytest.MonkeyPatch], None], tuple[str, ...]]] = {
    "left_out_session_fitted_on_scored_rows": (
        "a left-out session's frame and own terms fitted on the rows that score it, said so in "
        "its rows but not in its score (held out, not in-sample)",
        left_out_session_fitted_on_scored_rows(said=True),
        (LOSO_ROWS,),
    ),
    "left_out_session_fitted_on_scored_rows_unsaid": (
        "the same, its report naming the registration rows as the rows it was fitted on",
        left_out_session_fitted_on_scored_rows(said=False),
        (LOSO_ROWS,),
    ),
    "session_prior_10x_tight": (
        "a new session's corrections to the shared terms held by a prior of 1e-5 rad, not 1e-4",
        session_prior_10x_tight,
        (
            "tests/estimators/test_arm_session.py::"
            "test_a_sessions_shift_is_recovered_not_pulled_to_the_machines_value",
        ),
    ),
    "arm_cable_coupling_transposed": (
        "the estimators' cable compliance applied through the coupling transposed",
        arm_cable_coupling_transposed,
        (f"{CABLES}::test_fit_recovers_each_cable_through_an_asymmetric_coupling",),
    ),
    "twin_cable_coupling_transposed": (
        "the twin's cables settling the links through the coupling transposed",
        twin_cable_coupling_transposed,
        (f"{CABLES}::test_the_twins_cables_hold_gravity_through_an_asymmetric_coupling",),
    ),
    "cable_scale_in_motor_units": (
        "a cable's typical size taken at the motor, in the coupling's unit, not at its joints",
        cable_scale_in_motor_units,
        (f"{UNITS}::test_each_cable_is_the_same_at_the_joints_in_any_unit",),
    ),
    "compliance_below_zero_used": (
        "fit's compliances solved without their bound at zero",
        compliance_below_zero_used,
        (f"{UNITS}::test_no_cable_is_used_below_zero",),
    ),
    "compliance_implausible_ignored": (
        "discover naming a joint's compliance fitted below zero",
        compliance_implausible_ignored,
        (
            "tests/estimators/test_discovery.py::"
            "test_a_compliance_below_zero_is_never_accepted_whatever_it_cuts",
        ),
    ),
    "directions_over_fitted_rows": (
        "the drives' directions of last motion taken over the fitted rows alone",
        directions_over_fitted_rows,
        ("tests/scenarios/test_arm_cable_friction.py::test_a_row_held_out_still_moved_the_drives",),
    ),
}
