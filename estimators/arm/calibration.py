"""A serial arm calibrated on points measured in an instrument's frame: the robust, reweighted
fit of ``calibench fit arm-cmm`` (and of ``discover``'s geometry), a new setup's frame registered
on part of its rows, and the error statistics a fit is judged by.

:func:`calibrate` works on the stacked rows of one or several recordings, each with its own base
frame; the kinematic parameters, the tool point and (``model="physics"``) the compliance of the
joints gravity loads (:func:`loaded_joints`) are shared. The order of work, each step on what the
previous left:

1. register each base and the tool point on the nominal arm (the laser-tracker seed's base and
   Tool0 calibration), then find the identifiable parameters at that state (without the prior,
   which would make every parameter "identifiable") and solve for them, each kinematic error
   with a prior of its typical size (:data:`PRIOR`);
2. weight: the instrument's stated sigma plus a model-error variance per recording estimated
   from its residuals (so the reported std mean what they say, and a setup the model fits worse
   weighs less), and refit, twice;
3. leave out rows whose residual no Gaussian scatter of their recording's size explains
   (:data:`OUTLIER_P`), and start over from 1 on the rest (at most four rounds).

The estimate and its covariance are the last identification's
(:attr:`ArmCalibration.ident`: the kept parameters' values, std and covariance).
"""

from __future__ import annotations

import dataclasses
from typing import cast

import numpy as np

from calibench.estimators.arm.kinematics import (
    Chain,
    gravity_torques,
    in_readings,
    parallel_axes_note,
)
from calibench.estimators.arm.parameters import COMPLIANCE_PREFIXES
from calibench.estimators.arm.point import PointProblem, PointState
from calibench.estimators.arm.terms import directions
from calibench.estimators.identification.basis import Basis, identifiable_basis
from calibench.estimators.identification.solver import Identification, identify
from calibench.estimators.rotations import rigid_transform

# The kinematic errors' prior, in their typical sizes (0.1 mm, 1 mrad): a machined arm's
# tolerances. On the UR10 trained on its random poses (ur10_C) it is what carries the fit to the
# other side of the robot (held-out ur10_B: 0.63 mm without, 0.49 with); on enough data it
# changes nothing (all four series: the same figures to 0.001 mm).
PRIOR = 1.0
# A row is left out when no Gaussian scatter of its recording's size explains its residual:
# |e|^2 / s^2 beyond chi2(3)'s 1 - OUTLIER_P quantile (30.66), s^2 from the recording's median
# (chi2(3)'s median is 2.366).
OUTLIER_P = 1e-6
CHI2_3_QUANTILE = 30.66
CHI2_3_MEDIAN = 2.366
# a cable is far softer than a gearbox (a cable-driven wrist: 1e3 N m / rad against a geared
# joint's 1e5), so a motor carrying a fiftieth of the most loaded one's torque still stretches
# its cable measurably
CABLE_LOADED_FRACTION = 0.02
LOADED_FRACTION = 0.1  # a joint whose gravity torque stays under 10 % of the most loaded one's


class DegenerateFit(ValueError):
    """Data that cannot determine the fit: too few postures for the parameters, a singular
    system, rows to register a frame on that lie on one line."""


@dataclasses.dataclass
class ArmCalibration:
    """A fitted arm.

    problem : the last round's problem (its rows: the input's less the outliers; its weights).
    ident : the identification: the kept parameters' estimate, std and covariance, the basis.
    model : ``"geometry"`` or ``"physics"``.
    compliance_dropped : {parameter: why} for the compliances not estimated and the tool
        components held at the drawing's value.
    outliers : (k,) indices into the input's rows that were left out of the last fit.
    sigma_model_mm : the model-error sigma over all rows (mm).
    names : the problem's parameter names.
    """

    problem: PointProblem
    ident: Identification
    model: str
    compliance_dropped: dict
    outliers: np.ndarray
    sigma_model_mm: float
    names: tuple

    @property
    def state(self) -> PointState:
        """The identification's final state."""
        return cast(PointState, self.ident.state)


def loaded_joints(
    chain: Chain, q_rad: np.ndarray, fraction: float = LOADED_FRACTION
) -> tuple[tuple[int, ...], dict[str, str]]:
    """The joints whose compliance is a parameter: those whose gravity torque over the postures
    is large enough for it to show, beside the most loaded joint that carries the same tools (on
    a serial arm, every joint; on a torso with two arms, an arm's joints beside that arm's, not
    beside the torso's, which carries both).

    Parameters
    ----------
    chain : the arm (no masses: no joint).
    q_rad : (n, N) postures.
    fraction : the share of the most loaded joint's peak torque a joint needs.

    Returns
    -------
    (joints, why) : the joints (1-based) whose peak gravity torque is at least
    ``fraction`` of the most loaded joint's carrying its tools, and {``compliance<j>``: why} for
    the others.
    """
    if not chain.has_masses:
        return (), {}
    # on the readings: a joint carries what the joints that follow it carry (by their share)
    tau = np.abs(in_readings(chain, gravity_torques(chain, q_rad)))
    peak = tau.max(axis=0)
    branch = [tuple(c) for c in chain.on_path.T]  # the tools each joint carries
    tops = {b: max(max(p for p, c in zip(peak, branch) if c == b), 1e-12) for b in branch}
    keep, why = [], {}
    for j, p in enumerate(peak, 1):
        top = tops[branch[j - 1]]
        if j in chain.followers:
            why[f"compliance{j}"] = (
                f"joint {j} follows others (no encoder of its own): its load is theirs, and "
                "their compliance carries it"
            )
        elif p >= fraction * top:
            keep.append(j)
        else:
            why[f"compliance{j}"] = (
                f"joint {j} carries at most {p:.2g} N m of gravity torque here (under "
                f"{100 * fraction:.0f} % of the {top:.3g} N m of the most loaded joint"
                f"{' on its branch' if len(tops) > 1 else ''}): its compliance would not show"
            )
    return tuple(keep), why


def flexing_links(chain: Chain) -> tuple[tuple[int, ...], dict[str, str]]:
    """On a branched arm with masses, the links whose lateral flex is a parameter: those where
    its branches meet (a link that carries two or more joints or tools), whose weight beyond them
    bends them across. None on a serial arm (its links' flex, where any, the joints' compliance
    and the geometry absorb: the serial model is as it was).

    Returns
    -------
    (links, why) : the links (1-based joints) kept, {``flex_compliance<j>``: why} for a link
    where branches meet that has no length to bend.
    """
    if not chain.has_masses:
        return (), {}
    N = chain.n_joints
    children = np.bincount(chain.frames, minlength=N + 1)[1:]
    children += np.bincount(chain.tool_frames, minlength=N + 1)[1:]
    nominal = chain.nominal()
    keep, why = [], {}
    for j in np.flatnonzero(children >= 2) + 1:
        a, d = nominal[j - 1, :2]
        # the link from its joint's axis to its frame: (a, d) in DH, d alone in modified DH
        length = float(np.hypot(a, d) if chain.convention == "dh" else abs(d))
        if length >= 1.0:
            keep.append(int(j))
        else:
            why[f"flex_compliance{j}"] = (
                f"link {j} carries the branches but has no length ({length:.2g} mm) to bend"
            )
    return tuple(keep), why


def loaded_motors(chain: Chain, q_rad: np.ndarray) -> tuple[tuple[int, ...], dict[str, str]]:
    """For an arm with a transmission (``chain.coupling``): the motors whose cable compliance is a
    parameter, by :func:`loaded_joints`' rule on the torques the coupling carries back to the
    motors (coupling.T @ the joints' gravity torques).

    Returns
    -------
    (motors, why) : the motors (1-based) kept, and {``cable_compliance<m>``: why} for the others.
    """
    if not chain.has_masses or chain.coupling is None:
        return (), {}
    coupling = np.asarray(chain.coupling, float)
    # each motor's torque over its column's norm: the joint-side torque, whatever the unit its
    # angle is written in (a column scaled by 1 / s carries back a torque scaled by 1 / s)
    norm = np.maximum(np.linalg.norm(coupling, axis=0), 1e-300)
    tau = np.abs(gravity_torques(chain, q_rad) @ coupling) / norm
    peak = tau.max(axis=0)
    top = max(peak.max(), 1e-12)
    keep = tuple(m for m, p in enumerate(peak, 1) if p >= CABLE_LOADED_FRACTION * top)
    why = {
        f"cable_compliance{m}": (
            f"motor {m}'s cable carries at most {p:.2g} N m of gravity torque here, seen at the "
            f"joints (under {100 * CABLE_LOADED_FRACTION:.0f} % of the {top:.3g} N m of the most "
            "loaded motor): "
            "its stretch would not show"
        )
        for m, p in enumerate(peak, 1)
        if m not in keep
    }
    return keep, why


def calibrate(
    chain: Chain,
    q_rad: np.ndarray,
    xyz_mm: np.ndarray,
    recording: np.ndarray,
    sigma_mm: np.ndarray | None,
    model: str,
    parallel=(),
    robust: bool = True,
    prior: float | None = PRIOR,
    angle_terms=(),
    dirs: np.ndarray | None = None,
    tool: np.ndarray | None = None,
) -> ArmCalibration:
    """The module's recipe on stacked rows of one or several recordings.

    Parameters
    ----------
    chain : the nominal arm (its ``tool_mm`` the first guess of the tool point).
    q_rad : (n, N) encoder readings.
    xyz_mm : (n, 3) measured points, each in its recording's instrument frame.
    recording : (n,) int, the recording (own base frame) of each row, 0 .. R - 1.
    sigma_mm : (n, 3) the instrument's stated 1-sigma per value, or None.
    model : ``"geometry"``, or ``"physics"`` (adds the loaded joints' compliance; for an arm
        with a transmission, the loaded motors' cables' instead: a cable that drives one joint
        alone is that joint's compliance under another name; on a branched arm besides, the
        lateral flex of the links where its branches meet, :func:`flexing_links`).
    parallel : consecutive joint pairs (1-based) with parallel axes, for the dropped
        parameters' reasons.
    robust : whether to leave out the rows no Gaussian scatter explains (step 3).
    prior : the kinematic errors' prior in units of their typical size; None: none.
    angle_terms : :class:`~calibench.estimators.arm.terms.AngleTerm` s, joint-angle errors
        (a discovery's).
    dirs : (n, 2 N) the joints' and motors' directions of last motion at the rows, taken over
        their recordings' every row (:func:`~calibench.estimators.arm.terms.directions`); None:
        over these rows, in their order. Only direction terms read them.
    tool : (n,) int, each row's tool (0-based) on an arm with several; None: the first.

    Returns
    -------
    ArmCalibration

    Raises
    ------
    DegenerateFit
        When there are too few postures for the parameters, or the system is singular (an arm
        whose links have no length, postures that never move the tool point).
    """
    try:
        return _calibrate(
            chain,
            q_rad,
            xyz_mm,
            recording,
            sigma_mm,
            model,
            parallel,
            robust,
            prior,
            angle_terms,
            dirs,
            tool,
        )
    except np.linalg.LinAlgError:
        raise DegenerateFit(
            "the postures and the arm leave the fit singular: the measured points cannot determine "
            "even the base frame and the tool (an arm without length? postures that never move the "
            "tool point?)"
        ) from None


def _calibrate(
    chain,
    q_rad,
    xyz_mm,
    recording,
    sigma_mm,
    model,
    parallel,
    robust,
    prior,
    angle_terms,
    dirs,
    tool,
) -> ArmCalibration:
    """:func:`calibrate`, its singular systems not yet said."""
    joints: tuple[int, ...] = ()
    motors: tuple[int, ...] = ()
    links: tuple[int, ...] = ()
    why: dict[str, str] = {}
    if model == "physics" and chain.coupling is not None:
        motors, why = loaded_motors(chain, q_rad)
    elif model == "physics":
        joints, why = loaded_joints(chain, q_rad)
    if model == "physics":
        links, flat = flexing_links(chain)
        why = {**why, **flat}
    keep = np.ones(len(q_rad), bool)
    outliers = np.zeros(0, int)
    # the drives' directions over every row in its order: a row left out does not move them
    if dirs is None and any(t.kind == "direction" for t in angle_terms):
        coupling = None if chain.coupling is None else np.asarray(chain.coupling, float)
        dirs = directions(q_rad, recording, coupling)
    for _ in range(4):
        problem = PointProblem(
            chain,
            q_rad[keep],
            xyz_mm[keep],
            recording[keep],
            None if sigma_mm is None else sigma_mm[keep],
            compliance_joints=joints,
            prior=prior,
            angle_terms=angle_terms,
            cable_motors=motors,
            dirs=None if dirs is None else dirs[keep],
            flex_links=links,
            tool=None if tool is None else tool[keep],
        )
        held = problem.held_tool()
        n_par = len(problem.names)
        if 3 * keep.sum() <= n_par + 3:
            raise DegenerateFit(
                f"{keep.sum()} postures for {n_par} parameters (base frames, tool, kinematics): "
                "far too few to calibrate"
            )
        reg = identify(problem, Basis(np.sort(problem.always), {}))
        # what the data determine, without the prior (which would make everything "identifiable")
        problem.prior = None
        basis = identifiable_basis(problem, reg.state, note=parallel_axes_note(list(parallel)))
        problem.prior = prior
        ident, basis, bound = identify_physical(problem, basis, cast(PointState, reg.state))
        sigma = 0.0
        for _ in range(2):
            # the solver hands back the problem's own state type
            state = cast(PointState, ident.state)
            sigma = problem.reweight(state, 3 * keep.sum() - len(basis.kept))
            ident, basis, more = identify_physical(problem, basis, state)
            bound |= more
        if not robust:
            break
        e = (problem.y - problem.model(cast(PointState, ident.state))) * problem.weights()
        d2 = np.sum(e * e, axis=1)
        # each recording against its own scatter
        s2 = (
            np.array([np.median(d2[problem.rec == r]) for r in range(problem.n_rec)])
            / CHI2_3_MEDIAN
        )
        bad = d2 > CHI2_3_QUANTILE * s2[problem.rec]
        if not bad.any():
            break
        rows = np.flatnonzero(keep)
        outliers = np.r_[outliers, rows[bad]]
        keep[rows[bad]] = False
    return ArmCalibration(
        problem, ident, model, {**why, **held, **bound}, np.sort(outliers), sigma, problem.names
    )


COMPLIANCES = COMPLIANCE_PREFIXES
IMPLAUSIBLE_Z = 2.0  # a compliance this many std below zero: the data push it out, not scatter


def identify_physical(
    problem: PointProblem, basis: Basis, state: PointState
) -> tuple[Identification, Basis, dict[str, str]]:
    """:func:`identify`, every compliance at or above zero: an active set. While a kept
    compliance is fitted below zero, the one furthest below (in its std) is held at zero, its
    bound, and the rest fitted again. A compliance below zero is a joint or cable that pushes
    back harder the more it is loaded: within :data:`IMPLAUSIBLE_Z` std of zero it sits at its
    bound, beyond that the data push it out of its physical range (another effect in a
    compliance's clothes) and it is said implausible. Never used either way.

    Returns
    -------
    (ident, basis, why) : the identification, its basis (the held compliances among the dropped)
        and {held compliance: why}.
    """
    names = problem.names
    why: dict[str, str] = {}
    while True:
        ident = identify(problem, basis, state)
        below = [
            (ident.estimate[n] / max(ident.std[n], 1e-300), n)
            for n in (names[k] for k in basis.kept)
            if n.startswith(COMPLIANCES) and ident.estimate[n] < 0
        ]
        if not below:
            return ident, basis, why
        z, name = min(below)
        c, std = 1e6 * ident.estimate[name], 1e6 * ident.std[name]
        fitted = f"fitted at {c:.3g} +- {std:.2g} urad / N m"
        why[name] = (
            f"implausible: {fitted}, {-z:.1f} std below zero (a stiffness that pushes back harder "
            "the more it is loaded): the data push it out of its physical range, which another "
            "effect usually explains (`calibench discover`); left out of the model"
            if z < -IMPLAUSIBLE_Z
            else f"at its physical bound: {fitted}, within {-z:.1f} std of zero; held at zero"
        )
        k = names.index(name)
        basis = dataclasses.replace(
            basis,
            kept=basis.kept[basis.kept != k],
            dropped={**basis.dropped, name: why[name]},
        )
        state = cast(PointState, ident.state)
        comp = state.comp.copy()
        comp[k - problem.nk] = 0.0
        state = dataclasses.replace(state, comp=comp)


@dataclasses.dataclass(frozen=True)
class FrameRegistration:
    """A recording's instrument frame, registered on some of its rows.

    R, t : (3, 3), (3,) mm: instrument point = R @ base point + t.
    register_rows : (k,) the rows it was registered on, in the drawn order.
    judge_rows : (m,) the other usable rows, sorted: the ones to judge a fit on.
    """

    R: np.ndarray
    t: np.ndarray
    register_rows: np.ndarray
    judge_rows: np.ndarray


def register_frame(
    base_points_mm: np.ndarray,
    xyz_mm: np.ndarray,
    usable: np.ndarray,
    fraction: float,
    seed: int,
) -> FrameRegistration:
    """Register a recording from another setup on a drawn ``fraction`` of its usable rows (at
    least 3), by a rigid fit of the modelled points to the measured ones; the other usable rows
    are left to judge the model on.

    Parameters
    ----------
    base_points_mm : (n, 3) the fitted model's points in the arm's base frame.
    xyz_mm : (n, 3) the measured points in the recording's instrument frame.
    usable : (n,) bool, the rows that may be used.
    fraction : the share of the usable rows to register on.
    seed : the seed of the draw (fixed, so that runs compare).

    Returns
    -------
    FrameRegistration

    Raises
    ------
    DegenerateFit
        When no usable row is left to judge on, or the rows to register on measure points on one
        line (or one point), which cannot fix the frame's rotation.
    """
    order = np.random.default_rng(seed).permutation(np.flatnonzero(usable))
    k_reg = max(int(round(fraction * len(order))), 3)
    reg_rows, eval_rows = order[:k_reg], np.sort(order[k_reg:])
    if len(eval_rows) == 0:
        raise DegenerateFit(
            f"{len(order)} usable rows; a new frame needs rows to register on and rows to judge"
        )
    sv = np.linalg.svd(xyz_mm[reg_rows] - xyz_mm[reg_rows].mean(axis=0), compute_uv=False)
    if sv[1] < max(1e-3 * sv[0], 1.0):
        raise DegenerateFit(
            f"the {len(reg_rows)} rows a new frame is registered on measure points on one line "
            "(or one point): they cannot fix the frame's rotation"
        )
    R, t = rigid_transform(base_points_mm[reg_rows], xyz_mm[reg_rows])
    return FrameRegistration(R, t, reg_rows, eval_rows)


def error_statistics(e_mm: np.ndarray) -> dict:
    """The figures a fit is judged by, of 3-D errors.

    Parameters
    ----------
    e_mm : (n, 3) modelled minus measured points (or the reverse), mm.

    Returns
    -------
    {"samples": n, "mean_mm", "rms_mm", "max_mm", "p95_mm"} of the errors' lengths.
    """
    d = np.linalg.norm(e_mm, axis=1)
    return {
        "samples": int(len(d)),
        "mean_mm": float(d.mean()),
        "rms_mm": float(np.sqrt(np.mean(d * d))),
        "max_mm": float(d.max()),
        "p95_mm": float(np.percentile(d, 95)),
    }
