"""ISO 9283's repeatability RP from a real recording's repeated postures, beside the twin's.

``calibench acceptance arm-cmm --test iso9283 --recording CSV``: the recording's postures visited
more than once (every joint within :data:`Q_TOL_DEG`) are grouped; a group holding a stale
reading or a repeat that disagrees with its own (``estimators/arm/screening.py``: ten times the
recording's median repeat distance, and 0.1 mm) is left out and listed; the others' scatter is
pooled into one covariance, and the RP a pose of that scatter shows at ISO 9283's 30 cycles is
stated (``estimators/arm/repeatability.py``), with its standard uncertainty from the pooled
degrees of freedom (the scatter taken as one at every posture, as the standard's five poses are
taken to speak for the workspace). A branched arm's rows of different tools are never repeats.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from calibench.estimators.arm.repeatability import (
    expected_rp,
    group_scatter_mm,
    pooled_covariance,
    repeat_groups,
)
from calibench.estimators.arm.screening import screen
from calibench.scenarios.arm_cmm.acceptance import CYCLES
from calibench.scenarios.arm_cmm.training import load_recording
from calibench.scenarios.report import BadInput
from calibench.scenes.arm_cmm import ArmDescription

Q_TOL_DEG = 0.05  # one commanded posture's readings lie within this of each other, per joint


def recording_rp(path: Path, arm: ArmDescription) -> dict:
    """The RP (mm) at :data:`CYCLES` cycles from ``path``'s repeated postures, and how it was
    found: the groups, the rows left out and why, the pooled per-axis std."""
    rec = load_recording(path, arm)
    q = rec.q_rad if rec.tool is None else np.c_[rec.q_rad, 1e3 * rec.tool]
    groups = repeat_groups(q, Q_TOL_DEG)
    s = screen(rec.q_rad, rec.xyz_mm, Q_TOL_DEG, tool=rec.tool)
    suspect = np.r_[s.stale, s.pairs.ravel()].astype(int)
    left_out = sorted({int(g) for g in groups[suspect] if g >= 0})
    kept = np.where(np.isin(groups, left_out), -1, groups)
    if not np.any(kept >= 0):
        raise BadInput(
            f"{path}: no posture is visited twice (every joint within {Q_TOL_DEG} deg): "
            "no repeatability to state"
        )
    try:
        cov, dof = pooled_covariance(rec.xyz_mm, kept)
    except ValueError as e:
        raise BadInput(f"{path}: {e}") from None
    rp = expected_rp(cov, CYCLES)
    _, rms = group_scatter_mm(rec.xyz_mm, kept)
    return {
        "recording": str(path),
        "rows": len(rec),
        "groups": int(len(rms)),
        "rows_in_groups": int(np.sum(kept >= 0)),
        "dof": dof,
        "std_mm": np.sqrt(np.diag(cov)).round(5).tolist(),
        "median_group_rms_mm": float(np.median(rms)),
        "RP_mm": rp,
        # RP scales with s; s^2 from 3 dof chi-square draws a coordinate: u(s) / s = 1 / sqrt(6 dof)
        "u_RP_mm": rp / np.sqrt(6 * dof),
        "left_out": [
            {
                "rows": np.flatnonzero(groups == g).tolist(),
                "why": "a stale reading or a repeat that disagrees with its own",
            }
            for g in left_out
        ],
        "procedure": (
            f"postures read within {Q_TOL_DEG} deg at every joint grouped as one commanded pose; "
            "groups with a stale or disagreeing reading left out; the scatter about each "
            f"group's mean pooled; RP = E[l_mean + 3 S_l] over {CYCLES} cycles of that scatter "
            "(ISO 9283 7.2.2), one scatter taken for every posture"
        ),
    }
