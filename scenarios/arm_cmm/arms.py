"""Arms for the scenarios: the description (scenes) as the estimators' chain."""

from __future__ import annotations

import numpy as np

from calibench.estimators.arm.kinematics import Chain
from calibench.scenes.arm_cmm import ArmDescription, ArmFileError, load_arm  # noqa: F401  (re-exported)


def chain_of(arm: ArmDescription, tool_mm=None) -> Chain:
    """The estimators' view of an arm description (nominal values, masses, tool)."""
    f = lambda v: None if v is None else np.array(v, float)  # noqa: E731
    return Chain(
        arm.convention,
        f(arm.a_mm),
        f(arm.d_mm),
        f(arm.alpha_rad),
        f(arm.theta_rad),
        f(arm.tool_mm if tool_mm is None else tool_mm),
        f(arm.mass_kg),
        f(arm.com_mm),
        arm.tool_mass_kg,
        f(arm.gravity_m_s2),
    )
