"""The joint-angle effects a ``discover arm-cmm`` found, read from its discovery.json, as terms
of ``fit arm-cmm``'s model (``--effects``): transmission harmonics, encoder eccentricity, a
nonsmooth table over a joint's angle, a joint's lost motion and a motor's cable friction (by the
direction each last turned). Every defect of the file is one BadInput line."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from calibench.estimators.arm.terms import AngleTerm
from calibench.scenarios.arm_cmm import NAME
from calibench.scenarios.report import BadInput


def angle_terms_from_discovery(path, n_joints: int, n_recordings: int = 1) -> list[AngleTerm]:
    """The joint-angle effects of a ``discover arm-cmm`` result (a discovery.json's path, or its
    content) as terms of the fit: transmission harmonics, encoder eccentricity, a nonsmooth table
    over a joint's angle. A transmission with ``"per_recording": true`` gets its own phase and
    amplitude in each of the ``n_recordings`` training recordings (a motor-side error whose phase
    to the joint's angle is set at each power-up)."""
    if isinstance(path, dict):
        d, path = path, "the discovery"
    elif not str(path).strip():
        raise BadInput("--effects is empty: give a discovery.json, or discover")
    else:
        try:
            d = json.loads(Path(path).read_text())
        except OSError as e:
            raise BadInput(f"cannot read {path}: {e.strerror}") from None
        except (json.JSONDecodeError, UnicodeDecodeError):
            raise BadInput(f"{path} is not a discovery.json (not JSON)") from None
    if (
        not isinstance(d, dict)
        or d.get("scenario") != NAME
        or not isinstance(d.get("effects"), list)
    ):
        raise BadInput(f"{path} is not the discovery.json of an arm-cmm recording")
    terms = []
    for k, effect in enumerate(d["effects"]):
        if not isinstance(effect, dict) or not isinstance(effect.get("params", {}), dict):
            raise BadInput(f"{path}: effect {k + 1} is not an object with a name and its params")
        name, p = effect.get("name"), effect.get("params", {})
        if name not in ARM_EFFECTS:
            raise BadInput(
                f"{path}: effect {name!r} is not an arm's "
                f"(the arm's effects: {', '.join(ARM_EFFECTS)})"
            )
        if name == "cable_friction":
            terms.append(_cable_friction(p, n_joints, path))
            continue
        if name not in ("transmission", "encoder_eccentricity", "nonsmooth", "backlash"):
            continue  # the model's own (geometry, compliance) or none the fit has a term for
        j = p.get("joint")
        if isinstance(j, bool) or not isinstance(j, int) or not 1 <= j <= n_joints:
            raise BadInput(
                f"{path}: effect {name} names joint {j!r}; the arm has {n_joints} joints"
            )
        if name == "transmission":
            if not isinstance(p.get("per_recording", False), bool):
                raise BadInput(
                    f"{path}: per_recording of joint {j}'s transmission is true or false, "
                    f"not {p['per_recording']!r}"
                )
            recs = range(n_recordings) if p.get("per_recording") else [None]
            harmonics = _numbers(
                p.get("harmonics", []), f"{path}: joint {j}'s transmission harmonics", 0.0, 1e3
            )
            terms += [
                AngleTerm(j, "harmonic", harmonic=h, label="transmission", recording=r)
                for h in harmonics
                for r in recs
            ]
        elif name == "encoder_eccentricity":
            terms.append(AngleTerm(j, "harmonic", harmonic=1.0, label="eccentricity"))
        elif name == "backlash":
            terms.append(AngleTerm(j, "direction", label="backlash"))
        elif "edges_deg" in p:
            edges_deg = _numbers(p["edges_deg"], f"{path}: joint {j}'s edges_deg", -3600.0, 3600.0)
            if np.any(np.diff(edges_deg) <= 0):
                raise BadInput(f"{path}: joint {j}'s edges_deg must increase")
            terms.append(
                AngleTerm(
                    j,
                    "table",
                    edges_rad=tuple(np.r_[-np.inf, np.radians(edges_deg), np.inf]),
                    label="table",
                )
            )
    return terms


def _cable_friction(p: dict, n_joints: int, path) -> AngleTerm:
    """A motor's cable friction as the fit's term: its direction of last motion along its
    coupling column, as the discovery wrote them."""
    m = p.get("motor")
    if isinstance(m, bool) or not isinstance(m, int) or not 1 <= m <= n_joints:
        raise BadInput(f"{path}: cable_friction names motor {m!r}; the arm has {n_joints} motors")
    column = _numbers(p.get("column"), f"{path}: motor {m}'s coupling column", -1e9, 1e9)
    if len(column) != n_joints or not any(column):
        raise BadInput(
            f"{path}: motor {m}'s coupling column has {len(column)} values, not {n_joints}"
        )
    return AngleTerm(m, "direction", label="cable_friction", column=tuple(column))


# the effects a discover arm-cmm names (docs/formats.md's effect names for an arm)
ARM_EFFECTS = (
    "geometry",
    "joint_compliance",
    "cable_compliance",
    "encoder_eccentricity",
    "thermal_expansion",
    "thermal_drift",
    "transmission",
    "nonsmooth",
    "backlash",
    "cable_friction",
    "step",
)


def _numbers(values, what: str, lo: float, hi: float) -> list[float]:
    """A JSON list of plain numbers in (lo, hi], or one BadInput line saying what it holds."""
    if not isinstance(values, list) or not all(
        isinstance(v, (int, float)) and not isinstance(v, bool) for v in values
    ):
        raise BadInput(f"{what}: a list of numbers, not {values!r}")
    out = [float(v) for v in values]
    if not all(lo < v <= hi for v in out):
        raise BadInput(f"{what}: each between {lo:g} and {hi:g}, not {values!r}")
    return out
