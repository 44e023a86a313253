"""An arm recording's rows for discovery: which are usable (:func:`usable_rows`), their residual
against the replaying twin as one signal of a point's three coordinates (:func:`residual_signal`),
and the noise floor of what is left after the accepted effects (:func:`arm_floor`).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from calibench.estimators.discovery.fit import Signal
from calibench.estimators.discovery.noise import Floor, noise_floor
from calibench.scenarios.report import BadInput

# postures whose readings agree within this are one posture read again (encoders resolve
# microradians; a commanded posture's repeat differs by their noise, another posture by far more)
SAME_POSTURE_RAD = 1e-4
# successive postures closer than this (every joint) are near-repeats of what is smooth in them
NEAR_POSTURE_RAD = np.radians(0.5)


def arm_floor(r: np.ndarray, rows: ArmRows) -> Floor:
    """The noise floor of the arm's residual ``r`` (3 n,) after the accepted effects
    (:func:`~calibench.estimators.discovery.noise.noise_floor`): a posture read again at its
    shortest lags, and successive postures where the recording moves in small steps (a path, not
    random postures), each coordinate of each recording its own series."""
    from scipy.spatial import cKDTree

    q = np.asarray(rows.q_rad, float)
    n = len(q)
    ids = np.arange(n)
    # a branched arm's rows of one posture that measure other tools are no repeats
    key = (
        q / SAME_POSTURE_RAD if rows.tool is None else np.c_[q / SAME_POSTURE_RAD, 1e3 * rows.tool]
    )
    for i, j in sorted(cKDTree(key).query_pairs(1.0, p=np.inf)):
        ids[j] = min(ids[j], ids[i])
    order = np.arange(n, dtype=float) if rows.t_s is None else np.asarray(rows.t_s, float)
    steps = np.abs(np.diff(q, axis=0)).max(axis=1)[np.diff(rows.rec_id) == 0]
    near = len(steps) > 0 and float(np.quantile(steps, 0.9)) < NEAR_POSTURE_RAD
    return noise_floor(
        r,
        np.repeat(order, 3),
        np.repeat(ids, 3) * 3 + np.tile(np.arange(3), n),
        np.repeat(rows.rec_id, 3) * 3 + np.tile(np.arange(3), n),
        successive=near,
    )


@dataclasses.dataclass
class ArmRows:
    """The rows discovery reads, every recording's stacked in order.

    q_rad : (n, N) the readings; xyz_mm : (n, 3) the measured points, each in its recording's
    frame; rec_id : (n,) which recording; parts : each recording's rows kept, (k_i,) indices;
    left_out : the rows left out, with why (discovery.json's ``left_out_rows``); temp_c, t_s :
    (n,) the logged temperature and time, or None where a recording has none; tool : (n,) each
    row's tool (0-based) on a branched arm, or None where no recording has a ``tool`` column.
    """

    q_rad: np.ndarray
    xyz_mm: np.ndarray
    rec_id: np.ndarray
    parts: list[np.ndarray]
    left_out: list[dict]
    temp_c: np.ndarray | None
    t_s: np.ndarray | None
    tool: np.ndarray | None = None


def usable_rows(recs: list, arm) -> ArmRows:
    """The recordings' rows a discovery can use: the stale readings and both rows of each
    repeat that disagrees left out (without a calibrated model neither can be trusted), enough
    postures left for the arm's parameters, else one BadInput line."""
    from calibench.estimators.arm.screening import screen
    from calibench.scenarios.arm_cmm.training import check_postures

    N = arm.n_joints
    parts, left_out = [], []
    for k, r in enumerate(recs):
        if r.n_joints != N:
            raise BadInput(f"recording {k + 1} has {r.n_joints} joints, the arm {arm.name} {N}")
    check_postures(np.vstack([r.q_rad for r in recs]), len(recs))
    for k, r in enumerate(recs):
        flagged = screen(r.q_rad, r.xyz_mm, tool=r.tool)
        drop = sorted({int(i) for i in flagged.stale} | {int(i) for i in flagged.pairs.ravel()})
        parts.append(np.setdiff1d(np.arange(len(r.q_rad)), drop))
        tag = {} if len(recs) == 1 else {"recording": k + 1}
        left_out += [
            {**tag, "row": int(i), "why": "stale reading (repeats the previous row's point)"}
            for i in flagged.stale
        ]
        left_out += [
            {
                **tag,
                "row": int(i),
                "why": f"a repeat of row {int(o)} at the same angles disagrees by {d:.3f} mm",
            }
            for (a, b), d in zip(flagged.pairs, flagged.distance_mm)
            for i, o in ((a, b), (b, a))
        ]
    n = sum(len(k) for k in parts)
    n_kin = 4 * N + len(arm.parallel_pairs())
    if min(len(k) for k in parts) < 12 or n < max(40, 2 * n_kin):
        raise BadInput(
            f"{n} usable postures ({', '.join(str(len(k)) for k in parts)} per recording): "
            f"discover needs at least {max(40, 2 * n_kin)} for the {arm.name}'s parameters"
        )

    def joined(name: str) -> np.ndarray | None:
        cols = [getattr(r, name) for r in recs]
        if any(c is None for c in cols):
            return None
        return np.concatenate([c[k] for c, k in zip(cols, parts)])

    return ArmRows(
        np.vstack([r.q_rad[k] for r, k in zip(recs, parts)]),
        np.vstack([r.xyz_mm[k] for r, k in zip(recs, parts)]),
        np.concatenate([np.full(len(k), i) for i, k in enumerate(parts)]),
        parts,
        left_out,
        joined("temp_c"),
        joined("t_s"),
        None
        if all(r.tool is None for r in recs)
        else np.concatenate(
            [(np.zeros(len(r), int) if r.tool is None else r.tool)[k] for r, k in zip(recs, parts)]
        ),
    )


def residual_signal(chain, rows: ArmRows, state, drivers: dict, sim_mm: np.ndarray) -> Signal:
    """The residual signal (3 n,): the measured points in the arm's base frame less the twin's
    and the chain's remainder at the geometry's solution ``state``, with the scene model's free
    columns (each recording's frame: a small turn and shift; the shared tool point).

    The candidates are linear, the chain is not: over a 2 m arm a milliradian's error moves the
    point's lever arms, and a tool guessed 100 mm off moves every joint's. So every column is
    taken at the geometry's solution, and the signal loses the chain's remainder there
    (f(d*) - f(d_twin) - J(d*) (d* - d_twin)): the geometry term then holds exactly at d*.
    """
    from calibench.estimators.arm.kinematics import pose
    from calibench.estimators.rotations import skew

    rec_id, n = rows.rec_id, len(rows.q_rad)
    # each recording's points in the arm's base frame, by the frame the geometry's fit found
    meas_base = np.einsum("nji,nj->ni", state.R[rec_id], rows.xyz_mm - state.t[rec_id])
    at_twin = pose(chain, rows.q_rad, drivers["delta_twin"], rows.tool).point
    remainder = (
        drivers["point"]
        - at_twin
        - np.einsum("nij,j->ni", drivers["J"], state.delta - drivers["delta_twin"])
    )
    r = meas_base - sim_mm - remainder
    n_rec, T = len(rows.parts), chain.n_tools
    frame = np.zeros((n, 3, 6 * n_rec + 3 * T))
    for i in range(n_rec):
        m = rec_id == i
        frame[m, :, 6 * i : 6 * i + 3] = -skew(drivers["point"][m])
        frame[m, :, 6 * i + 3 : 6 * i + 6] = np.eye(3)
    tool = np.zeros(n, int) if rows.tool is None else rows.tool
    for k in range(T):  # each tool's point, on the rows that measure it
        m = tool == k
        frame[m, :, 6 * n_rec + 3 * k : 6 * n_rec + 3 * k + 3] = drivers["flange_R"][m]
    return Signal(
        "xyz_meas - xyz_sim", "xyz", r.ravel(), frame.reshape(3 * n, -1), np.repeat(np.arange(n), 3)
    )
