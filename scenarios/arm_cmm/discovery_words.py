"""What the arm's discovery says beside its effects: where the residual is structured (against
each joint's angle and the temperature) and which candidates the postures cannot tell apart from
what was accepted, with the experiment that would.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from calibench.estimators.discovery.confounds import find_confounds
from calibench.estimators.discovery.fit import fit_terms
from calibench.estimators.discovery.locate import Driver, follows

ARM_EXPERIMENTS = {
    "joint_compliance": "take postures where the other joints change this joint's gravity torque "
    "(the elbow folded and stretched at the same shoulder angle), or add a known payload",
    "encoder_eccentricity": "take postures at the same gravity torque over the joint's whole turn",
    "transmission": "measure over a wider range of the joint's angle at a finer step",
    "thermal_expansion": "let the arm's temperature change by several K during the recording",
    "thermal_drift": "measure one posture again at the start, middle and end of the recording",
}


def torque_range(tau: np.ndarray) -> str:
    """``lo to hi`` of torques (n,) N m, to three figures of the larger (a torque a thousandth of
    it is 0, not -0.000534)."""
    lo, hi = float(np.min(tau)), float(np.max(tau))
    tiny = 1e-3 * max(abs(lo), abs(hi))
    lo, hi = (0.0 if abs(v) < tiny else v for v in (lo, hi))
    return f"{lo:.3g} to {hi:.3g}"


def arm_confounds(sig, terms, candidates, drivers, found) -> list[dict]:
    """Candidates the data cannot tell from what was accepted, in plain words: compliance and
    eccentricity of one joint look alike when its gravity torque is nearly a sinusoid of its own
    angle; a compliance the geometry absorbs within these postures (a narrow band of the joint)
    would still matter on postures that load the joint otherwise."""
    out = []
    accepted = {t.key for t in terms}
    asked = [
        c
        for c in candidates
        if c.key not in accepted and c.name in ("joint_compliance", "encoder_eccentricity")
    ]
    for f in find_confounds({sig.axis: sig}, {sig.axis: terms}, asked, drivers):
        c, frac = f.candidate, f.fraction
        other = (
            "encoder_eccentricity" if c.name == "joint_compliance" else "joint_compliance"
        ) + f":joint{c.joint}"
        if other in accepted:
            out.append(
                {
                    "effect": c.name,
                    "axis": "xyz",
                    "with": other,
                    "why": f"joint {c.joint}'s gravity torque is nearly a sinusoid of its own "
                    "angle in these "
                    f"postures: {100 * frac:.0f} % of {c.name}'s effect is what {other} already "
                    "explains",
                    "experiment": ARM_EXPERIMENTS[c.name],
                }
            )
        elif c.name == "joint_compliance" and np.ptp(drivers["tau"][:, c.joint - 1]) > 0:
            tau = drivers["tau"][:, c.joint - 1]
            out.append(
                {
                    "effect": c.name,
                    "axis": "xyz",
                    "with": "geometry",
                    "why": f"within these postures joint {c.joint}'s gravity torque "
                    f"({torque_range(tau)} N m) moves the point almost as the kinematic errors "
                    "do: "
                    f"{100 * frac:.0f} % of a compliance's effect is absorbed by them, so the "
                    "recording "
                    "cannot show it, yet a calibration without it will not carry to postures "
                    f"that load the joint otherwise",
                    "experiment": ARM_EXPERIMENTS[c.name],
                }
            )
    return out


def locate_arm(sig, terms, drivers, q, temp, seed) -> list[dict]:
    """The residual after the geometry against each joint angle and the temperature."""
    rng = np.random.default_rng(seed)
    n = len(q)
    geo = [t for t in terms if t.name == "geometry"]
    _, _, _, res = fit_terms(sig, geo, drivers, {}, None)
    res3 = res.reshape(n, 3)
    tested = [Driver(f"q{j}", q[:, j - 1]) for j in range(1, q.shape[1] + 1)]
    tested.append(Driver("temp_c", temp, "passes"))
    located: list[dict[str, Any]] = [
        {
            "signal": f"{'xyz'[f.column]}_meas - {'xyz'[f.column]}_sim (after geometry)",
            "driver": f.name,
            "score": f.score,
            "p_value": f.p,
            "where": f"over the whole range of {f.name}",
        }
        for f in follows(res3, tested, np.zeros(n), rng, n_perm=99)
    ]
    located.sort(key=lambda d: -d["score"])
    return located
