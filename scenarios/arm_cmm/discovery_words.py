"""What the arm's discovery says beside its effects: where the residual is structured (against
each joint's angle and the temperature) and which candidates the postures cannot tell apart from
what was accepted, with the experiment that would.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from calibench.estimators.discovery.confounds import find_confounds
from calibench.estimators.discovery.fit import fit_terms
from calibench.estimators.discovery.locate import Driver, change_point, follows

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


def arm_confounds(sig, terms, candidates, drivers, found, said=frozenset()) -> list[dict]:
    """Candidates the data cannot tell from what was accepted, in plain words: compliance and
    eccentricity of one joint look alike when its gravity torque is nearly a sinusoid of its own
    angle; a compliance the geometry absorbs within these postures (a narrow band of the joint)
    would still matter on postures that load the joint otherwise. ``said``: the keys of
    candidates already said confounded (a tie held out), left out here."""
    out = []
    accepted = {t.key for t in terms} | set(said)
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


# many tests at once (four drivers a joint): a finding needs no permuted score above its own
LOCATE_P = 0.002
LOCATE_PERMUTATIONS = 499


def locate_arm(sig, terms, drivers, seed) -> list[dict]:
    """Where the residual after the geometry lives, joint by joint: the point's residual seen as
    each joint's angle error (its least-squares projection on the joint's d(point) / d(q): an
    effect a joint's angle carries is modulated by the posture in xyz, and averages away in any
    coordinate's bins) against that joint's angle, its direction of last motion (beyond the
    angle, which random postures tie it to), the time (a change at one moment: the postures come
    in random order, so time itself is tested) and the temperature. Many tests at once: a
    finding needs p <= 0.002 from 499 permutations."""
    rng = np.random.default_rng(seed)
    q = np.asarray(drivers["q"], float)
    n, N = q.shape
    geo = [t for t in terms if t.name == "geometry"]
    _, _, _, res = fit_terms(sig, geo, drivers, {}, None)
    res3 = res.reshape(n, 3)
    Jq = np.asarray(drivers["Jq"], float)
    reach = np.einsum("nkj,nkj->nj", Jq, Jq)
    # the angle error (rad) of each joint that best explains each posture's residual
    angle = -np.einsum("nkj,nk->nj", Jq, res3) / np.maximum(reach, 1e-300)
    d = drivers.get("dir_q")
    located: list[dict[str, Any]] = []
    for j in range(1, N + 1):
        tested = [
            Driver(f"q{j}", q[:, j - 1]),
            Driver(f"dir_q{j}", None if d is None else d[:, j - 1], given=q[:, j - 1]),
            Driver("t_s", drivers.get("t_s"), "shuffle"),
            Driver("temp_c", drivers.get("temp_c"), "shuffle"),
        ]
        r = angle[:, j - 1]
        for f in follows(r, tested, np.zeros(n), rng, LOCATE_P, 0.02, LOCATE_PERMUTATIONS):
            located.append(
                {
                    "signal": f"joint {j}'s angle error (the residual after geometry, projected)",
                    "driver": f.name,
                    "joint": j,
                    "score": f.score,
                    "p_value": f.p,
                    "where": _where_on_arm(r, f.values, f.name, j),
                }
            )
    located.sort(key=lambda d: -d["score"])
    return located


def _where_on_arm(r: np.ndarray, v: np.ndarray, name: str, joint: int) -> str:
    """Where joint ``joint``'s angle error ``r`` (n,) rad follows the driver ``name`` (values
    ``v``), in words: a change at one moment, a direction's difference, a slope, or the angle's
    band with the largest mean."""
    if name == "t_s":
        order = np.argsort(v, kind="stable")
        k, stat = change_point(r[order])
        return f"joint {joint}: changes most after t = {v[order][k]:.0f} s (CUSUM {stat:.1f})"
    if name.startswith("dir_q"):
        return (
            f"joint {joint}: last turned forward minus backward "
            f"{1e6 * (r[v > 0].mean() - r[v < 0].mean()):+.0f} urad"
        )
    if name == "temp_c":
        return f"joint {joint}: {1e6 * np.polyfit(v, r, 1)[0]:+.1f} urad per K"
    edges = np.quantile(v, np.linspace(0, 1, 9))
    idx = np.clip(np.searchsorted(edges, v, side="right") - 1, 0, 7)
    means = np.array([np.mean(r[idx == k]) if np.any(idx == k) else 0.0 for k in range(8)])
    k = int(np.argmax(np.abs(means)))
    return (
        f"joint {joint}: largest at {np.degrees(edges[k]):.0f} to {np.degrees(edges[k + 1]):.0f} "
        f"deg ({1e6 * means[k]:+.0f} urad)"
    )
