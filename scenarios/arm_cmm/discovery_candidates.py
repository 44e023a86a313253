"""What the arm's discovery chooses among: the chain's geometry at fit's solution, each joint's
encoder eccentricity and transmission harmonics (one phase, or one per recording), the
compliances by fit's rules (:mod:`~calibench.scenarios.arm_cmm.discovery_compliance`), thermal
growth and drift; and, for what none of them explains, a table over one joint's angle.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from calibench.estimators.discovery.arm import (
    ArmDrift,
    ArmThermalExpansion,
    EncoderEccentricity,
    Geometry,
    TransmissionSearch,
    joint_table,
)
from calibench.estimators.discovery.arm_motion import CableFriction, JointBacklash
from calibench.estimators.discovery.effect import Drivers, Effect
from calibench.estimators.discovery.fit import Signal
from calibench.estimators.discovery.select import Discovery, keep_table
from calibench.estimators.discovery.step import StepSearch
from calibench.scenarios.arm_cmm.discovery_compliance import compliance_candidates


@dataclasses.dataclass
class ArmCandidates:
    """What the arm's discovery chooses among.

    candidates : those that apply to the rows; geometry : the chain's geometry among them, or
    None; not_applicable : {candidate: why it does not apply}; alike : {a candidate's key: the
    confound said when it is accepted}.
    """

    candidates: list[Effect | TransmissionSearch | StepSearch]
    geometry: Effect | None
    not_applicable: dict
    alike: dict


def arm_candidates(
    chain, arm, q_rad: np.ndarray, xyz_mm: np.ndarray, solved, drivers: dict
) -> ArmCandidates:
    """The candidates that apply at postures ``q_rad`` (n, N) with points ``xyz_mm`` (n, 3): the
    chain's geometry (its identifiable errors, with fit's prior, at the geometry's solution
    ``solved``, a fit's calibration), each joint's encoder eccentricity and transmission (one
    phase, and one per recording), the compliances by fit's rules, thermal growth and drift."""
    from calibench.estimators.arm.calibration import PRIOR
    from calibench.estimators.arm.kinematics import parameter_scales
    from calibench.estimators.discovery.harmonics import harmonic_grid

    N, q = arm.n_joints, q_rad
    # a follower has no reading of its own: what acts on a joint's reading is its joints'
    joints = [j for j in range(1, N + 1) if j not in chain.followers]
    problem, basis, s = solved.problem, solved.ident.basis, solved.state
    kin = tuple(int(k) for k in basis.kept if k < 5 * N)
    names = tuple(problem.names[k] for k in kin)
    # the prior's rows weigh as fit's do: the fit's scatter per value over each error's prior std
    noise_mm = float(np.sqrt(np.mean((xyz_mm - problem.model(s)) ** 2)))
    weight = noise_mm / (PRIOR * parameter_scales(names)) if PRIOR else ()
    geometry = Geometry(kept=kin, names=names, prior_weight=tuple(weight))
    # postures that move one joint only leave no kinematic error the frames and tool do not
    # absorb; a transmission's search fixes its harmonic on the rows it is fitted to (no Effect)
    candidates: list[Effect | TransmissionSearch | StepSearch] = [geometry] if kin else []
    candidates += [EncoderEccentricity(joint=j) for j in joints]
    candidates += [
        TransmissionSearch(joint=j, harmonics=harmonic_grid(q[:, j - 1])) for j in joints
    ]
    # several recordings: a joint's harmonic may also keep its frequency and take a phase per
    # recording (a motor-side error, its phase set at each power-up)
    candidates += [
        TransmissionSearch(joint=j, harmonics=harmonic_grid(q[:, j - 1]), per_recording=True)
        for j in joints
    ]
    compliance, not_applicable, alike = compliance_candidates(chain, q, drivers, arm.name)
    candidates += compliance
    candidates += [ArmThermalExpansion(), ArmDrift(driver="temp_c"), ArmDrift(driver="t_s")]
    # what follows a joint's motion or a moment, not its angle: lost motion, a step
    candidates += [JointBacklash(joint=j) for j in joints]
    # a differential's motor: its cables' friction turns its joints together (a motor that drives
    # one joint alone is that joint's lost motion under another name)
    if chain.coupling is not None:
        coupling = np.asarray(chain.coupling, float)
        candidates += [
            CableFriction(motor=m, column=tuple(coupling[:, m - 1]))
            for m in range(1, N + 1)
            if np.count_nonzero(coupling[:, m - 1]) > 1
        ]
    candidates += [StepSearch(axis="xyz", joint=j) for j in joints]
    candidates = [c for c in candidates if not hasattr(c, "applies") or c.applies(drivers)]
    return ArmCandidates(
        candidates, geometry if geometry in candidates else None, not_applicable, alike
    )


def add_joint_table(
    sig: Signal,
    found: Discovery,
    terms: dict,
    drivers: Drivers,
    fold: np.ndarray,
    q_rad: np.ndarray,
    floor: float,
) -> None:
    """What no candidate explains: a table over one joint's angle, each joint's proposed, the one
    that helps most kept by the engine's :func:`keep_table` if it cuts the held-out RMS by
    ``floor``."""
    followers = drivers.get("followers") or ()
    tables = [
        joint_table(q_rad[:, j - 1], j) for j in range(1, q_rad.shape[1] + 1) if j not in followers
    ]
    keep_table([sig], terms, found, drivers, fold, [t for t in tables if t is not None], floor)
