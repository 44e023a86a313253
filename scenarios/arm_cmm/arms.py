"""Arms for the scenarios: the description (scenes) as the estimators' chain, and which joints
gravity loads enough for their compliance to show."""

from __future__ import annotations

import numpy as np

from calibench.estimators.arm.kinematics import Chain, gravity_torques
from calibench.scenes.arm_cmm import ArmDescription, ArmFileError, load_arm  # noqa: F401  (re-exported)

LOADED_FRACTION = 0.1  # a joint whose gravity torque stays under 10 % of the most loaded one's


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


def loaded_joints(chain: Chain, q_rad: np.ndarray) -> tuple[tuple[int, ...], dict[str, str]]:
    """Joints (1-based) whose gravity torque over the postures ``q_rad`` (n, N) is large enough for
    their compliance to be a parameter, and why each other joint's is not."""
    if not chain.has_masses:
        return (), {}
    tau = np.abs(gravity_torques(chain, q_rad))
    peak = tau.max(axis=0)
    top = max(peak.max(), 1e-12)
    keep, why = [], {}
    for j, p in enumerate(peak, 1):
        if p >= LOADED_FRACTION * top:
            keep.append(j)
        else:
            why[f"compliance{j}"] = (
                f"joint {j} carries at most {p:.2g} N m of gravity torque here (under "
                f"{100 * LOADED_FRACTION:.0f} % of the {top:.3g} N m of the most loaded joint): "
                "its compliance would not show"
            )
    return tuple(keep), why
