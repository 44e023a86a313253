"""The arm's compliance candidates for ``discover arm-cmm``: each loaded joint's, for an arm
with a transmission each loaded motor's cable, and on a branched arm the lateral flex of each
link its branches meet on, by fit's own rules, with the words for the joints and cables that are
not offered and for a cable that is a joint's compliance under another name."""

from __future__ import annotations

import numpy as np


def compliance_candidates(chain, q: np.ndarray, drivers, name: str) -> tuple[list, dict, dict]:
    """The compliance candidates, by fit's rules: each joint gravity loads enough
    (:func:`~calibench.estimators.arm.calibration.loaded_joints`) and, for an arm with a
    transmission, each loaded motor's cable (:func:`loaded_motors`; the joints then by the cables'
    share, so that joint and cable compete on the same postures).

    Returns
    -------
    (candidates, not_applicable, alike) : the candidates; {key: why} for those not offered;
    {accepted joint key: confound} for a cable that drives one joint alone, which is that joint's
    compliance under another name (said when the joint's is accepted).
    """
    from calibench.estimators.arm.calibration import (
        CABLE_LOADED_FRACTION,
        loaded_joints,
        loaded_motors,
    )
    from calibench.estimators.discovery.arm_compliance import (
        CableCompliance,
        JointCompliance,
        LinkFlex,
    )

    if drivers["tau"] is None:
        return (
            [],
            {"joint_compliance": f"the arm file {name} gives no masses: no gravity torques"},
            {},
        )
    cabled = chain.coupling is not None
    loaded, unloaded = (
        loaded_joints(chain, q, CABLE_LOADED_FRACTION) if cabled else loaded_joints(chain, q)
    )
    out: list = [JointCompliance(joint=j) for j in loaded]
    out += [LinkFlex(link=j) for j in drivers.get("flex") or {}]
    why = {f"joint_compliance:joint{k.removeprefix('compliance')}": v for k, v in unloaded.items()}
    alike = {}
    if cabled:
        motors, unloaded = loaded_motors(chain, q)
        why.update(
            {
                f"cable_compliance:motor{k.removeprefix('cable_compliance')}": v
                for k, v in unloaded.items()
            }
        )
        C = np.asarray(chain.coupling, float)
        for m in motors:
            col = C[:, m - 1]
            joints = np.flatnonzero(col) + 1
            if len(joints) > 1:
                out.append(CableCompliance(motor=m, column=tuple(col)))
                continue
            j = int(joints[0])
            why[f"cable_compliance:motor{m}"] = (
                f"motor {m} drives joint {j} alone: its cable's stretch is joint {j}'s compliance "
                "under another name (one candidate for both)"
            )
            alike[f"joint_compliance:joint{j}"] = {
                "effect": "joint_compliance",
                "axis": "xyz",
                "with": f"cable_compliance:motor{m}",
                "why": f"motor {m} drives joint {j} alone: the stretch of its cable and the "
                f"compliance of joint {j}'s gearing turn the joint alike, and no posture tells "
                "them apart",
                "experiment": f"read joint {j}'s angle at the link (a second encoder after the "
                "cable), or measure the cable's stretch under a known torque on the bench",
            }
    return out, why, alike


def link_flex_columns(chain, P) -> dict[int, np.ndarray] | None:
    """On a branched arm with masses, how each link its branches meet on
    (:func:`~calibench.estimators.arm.calibration.flexing_links`) moves the points by bending
    across under the weight beyond its middle, per rad / N m: {link: (n, 3) mm}, at the pose
    ``P`` (each row's tool); None where no link is offered."""
    from calibench.estimators.arm.bending import flex_columns
    from calibench.estimators.arm.calibration import flexing_links
    from calibench.estimators.arm.kinematics import flex_moments

    if not chain.has_masses:
        return None
    links, _ = flexing_links(chain)
    if not links:
        return None
    cols = flex_columns(chain, P, np.array(links), flex_moments(chain, P, links))
    return {j: cols[:, :, i] for i, j in enumerate(links)}
