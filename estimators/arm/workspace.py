"""Where a calibration's training postures leave out part of the workspace: a joint that spans
a narrow arc, a joint's gravity torque seen with one sign only, test postures where no training
posture has been. Said in words, as warnings; the fit itself is not changed by them."""

from __future__ import annotations

import numpy as np

from calibench.estimators.arm.kinematics import Chain, gravity_torques

BIN_DEG = 10.0  # a joint's angle is "visited" by 10-degree bins


def visited_bins(q_deg: np.ndarray, bin_deg: float = BIN_DEG) -> np.ndarray:
    """Which ``bin_deg`` bins of each joint's angle (mod 360) the postures visit.

    Parameters
    ----------
    q_deg : (n, N) postures, degrees.
    bin_deg : the bins' width, degrees.

    Returns
    -------
    (N, 360 / bin_deg) bool.
    """
    b = (np.mod(q_deg, 360.0) // bin_deg).astype(int)
    out = np.zeros((q_deg.shape[1], int(360 / bin_deg)), bool)
    for j in range(q_deg.shape[1]):
        out[j, np.unique(b[:, j])] = True
    return out


def span_deg(q_deg: np.ndarray) -> float:
    """The arc a joint's angles cover: 360 minus the largest gap between them, mod 360.

    Parameters
    ----------
    q_deg : (n,) one joint's angles, degrees.

    Returns
    -------
    The arc, degrees.
    """
    a = np.sort(np.mod(q_deg, 360.0))
    gaps = np.diff(np.r_[a, a[0] + 360.0])
    return float(360.0 - gaps.max())


def coverage_warnings(
    chain: Chain, q_train: np.ndarray, tests: dict[str, np.ndarray], compliance_joints
) -> list[str]:
    """Where the training postures leave out part of the workspace that a test visits, or that a
    model would need to see (one sign of a joint's gravity torque, a narrow band of a joint).

    Parameters
    ----------
    chain : the arm (its masses, when it has them, give the gravity torques).
    q_train : (n, N) the training postures, rad.
    tests : {name: (m, N) postures, rad} of the recordings the fit is tested on.
    compliance_joints : the joints (1-based) whose compliance the fit estimates (the chain then
        has masses).

    Returns
    -------
    The warnings, one line each.
    """
    out = []
    qd = np.degrees(q_train)
    for j in range(qd.shape[1]):
        span = span_deg(qd[:, j])
        if span < 180.0:
            out.append(f"q{j + 1} spans only {span:.0f} deg in the training postures")
    if len(compliance_joints) and not chain.has_masses:
        raise ValueError("a joint's compliance needs the chain's masses (its gravity torques)")
    tau = gravity_torques(chain, q_train) if chain.has_masses else None
    if tau is not None:
        for j in compliance_joints:
            pos = float(np.mean(tau[:, j - 1] > 0))
            if pos < 0.02 or pos > 0.98:
                sign = "positive" if pos > 0.5 else "negative"
                out.append(
                    f"joint {j}'s gravity torque is {sign} in {100 * max(pos, 1 - pos):.0f} % "
                    "of the training postures: the model has not seen it loaded the other way"
                )
    arcs = visited_bins(qd)
    for name, q in tests.items():
        qt = np.degrees(q)
        b = (np.mod(qt, 360.0) // BIN_DEG).astype(int)
        for j in range(qt.shape[1]):
            outside = float(np.mean(~arcs[j, b[:, j]]))
            if outside > 0.1:
                out.append(
                    f"{name}: {100 * outside:.0f} % of its postures put q{j + 1} where no "
                    "training posture has it"
                )
        if tau is not None:
            tt = gravity_torques(chain, q)
            for j in compliance_joints:
                train_pos = np.mean(tau[:, j - 1] > 0)
                if train_pos < 0.02 or train_pos > 0.98:
                    other = float(np.mean((tt[:, j - 1] > 0) != (train_pos > 0.5)))
                    if other > 0.1:
                        out.append(
                            f"{name}: {100 * other:.0f} % of its postures load joint {j} the "
                            "other way"
                        )
    return out
