"""Scenario ``arm-cmm``: identify a serial arm's parameter errors with a laser tracker (and,
separately, with cones and a length bar), after choosing the postures.

The arm is the seed's 6-joint arm CMM unless the config names another (``arm = "ARM.toml"`` or a
built-in name such as ``ur10``; docs/formats.md, "Arm descriptions"). Its truth may carry joint
stiffness: the links then sag under gravity (MuJoCo's physics), which the geometry-only
identification here does not model, so a study shows what that costs.

1. Identifiability: the whitened Jacobian at the start, the tracker frame and the tool point
   always estimated, then the kinematic parameters (and Hayati's beta where two axes are
   parallel) by pivoted QR; the rest are dropped, with the reason.
2. Postures: 50 chosen greedily from 600 candidates to maximise the observability index O1
   (Borm and Menq's geometric mean of singular values), against 50 random ones.
3. Identification from tracker measurements (range and two angles, each with its noise), and
   from single-point articulation in two cones of a 600 mm bar.
4. Held-out postures: probe positions predicted with the nominal and the identified model
   against the truth.

Dropped parameters are absorbed by kept ones, so each kept parameter is compared with a
reference derived from the injected errors by the known relations (:func:`reference_values`),
never by the estimator under test; the parameters with no such relation (the frames, errors that
absorb others through the chain) are judged by the held-out positions MuJoCo gives.
"""

from __future__ import annotations

import dataclasses
import time
from pathlib import Path

import numpy as np

from calibench.estimators.arm.design import observability_index, select_postures
from calibench.estimators.arm.kinematics import Chain, param_names, parameter_scales, point
from calibench.estimators.arm.tracker import ConeProblem, TrackerProblem, TrackerState
from calibench.estimators.identification.basis import identifiable_basis
from calibench.estimators.identification.solver import Identification, identify_identifiable
from calibench.estimators.rotations import rigid_transform
from calibench.scenarios.arm_cmm import NAME
from calibench.scenarios.arm_cmm.arms import chain_of
from calibench.scenarios.arm_cmm.references import (
    TOL_SIGMA,
    is_angle,
    reference_values,
    tracker_parameters,
)
from calibench.scenarios.harness import write_outputs
from calibench.scenarios.report import BadInput, Check, Parameter, Report
from calibench.scenarios.run_recording import (
    MASSES_NEEDED,
    ArmRecordingPlan,
    check_arm_kind,
    check_plan,
    write_recording,
)
from calibench.scenes.arm_cmm import DEFAULT_ARM, ArmDescription
from calibench.sim.arm_cmm import ArmSim, ArmTruth


@dataclasses.dataclass(frozen=True)
class ArmCmmConfig:
    # a built-in arm's name or an ARM.toml; a description read once for a whole trial (prior)
    arm: str | ArmDescription = DEFAULT_ARM
    truth: ArmTruth = ArmTruth()
    n_postures: int = 50
    n_candidates: int = 600
    n_holdout: int = 100
    n_per_cone: int = 40
    cone_point_sigma_mm: float = (
        0.01  # encoders through the arm plus seating, as the user states it
    )
    bar_sigma_mm: float = 0.001
    after_limit_mm: float = 0.02  # the tracker's own noise is about 0.01 mm at 2.5 m
    # The instruments' 1-sigma as their datasheets state it, which is all the estimator is told
    # (the truth's *_noise_* is what the simulation draws): range a + b * L(m), angles, encoders.
    # The identification scales its covariance by the variance factor it finds in the residuals,
    # so a datasheet off by a common factor leaves the reported std honest.
    stated_range_sigma_um: tuple = (5.0, 1.0)
    stated_angle_sigma_urad: float = 4.0
    stated_encoder_sigma_urad: float = 5.0

    # [arm-cmm.recording]: what DIR/recording.csv records and conceals (run_recording.py)
    recording: ArmRecordingPlan = ArmRecordingPlan()

    def __post_init__(self):
        check_plan(NAME, self.recording)
        check_serial(self.arm)
        if self.recording.conceal in MASSES_NEEDED:  # said before the run, not after it
            from calibench.scenes.arm_cmm import load_arm

            arm = self.arm if isinstance(self.arm, ArmDescription) else load_arm(self.arm)
            check_arm_kind(NAME, self.recording, arm.has_masses, arm.name)
        if self.stated_range_sigma_um[0] <= 0:
            raise ValueError("stated_range_sigma_um: the range's constant term must be positive")
        if self.n_candidates < self.n_postures:
            raise ValueError(
                f"n_candidates = {self.n_candidates}: the plan picks n_postures = "
                f"{self.n_postures} of them, so at least that many"
            )

    @property
    def stated(self) -> tuple:
        """(range (a um, b um/m), angle urad, encoder urad): the datasheet's 1-sigma."""
        return (
            tuple(self.stated_range_sigma_um),
            self.stated_angle_sigma_urad,
            self.stated_encoder_sigma_urad,
        )


def check_serial(arm: str | ArmDescription) -> None:
    """``run`` and ``montecarlo`` simulate a serial arm's tracker, cone and bar procedures: a
    branched arm (a tree of joints, followers, several tools) is refused in one line, said where
    the config is read (an arm that cannot be read is said where it is loaded)."""
    from calibench.scenes.arm_cmm import BUILTIN, ArmFileError, load_arm

    if isinstance(arm, str) and arm in BUILTIN:
        return
    try:
        described = arm if isinstance(arm, ArmDescription) else load_arm(arm)
    except ArmFileError:
        return
    if described.branched:
        raise BadInput(
            f"config: arm-cmm.arm (or --arm): {described.name} is a branched arm (parent, follows "
            "or [[tool]] in its file): run and montecarlo simulate a serial arm's tracker, cone "
            "and bar procedures; calibrate a branched arm with fit arm-cmm or discover arm-cmm on "
            "its recordings"
        )


def tracker_problem(
    sim: ArmSim, chain: Chain, q_true, q_read, rng, stated: tuple | None = None
) -> TrackerProblem:
    """The tracker's measurements at motor angles ``q_true`` (n, N) with encoder readings
    ``q_read``; exact (no noise, no encoder noise in the model) without ``rng``. ``stated``: the
    1-sigma the estimator is told (:attr:`ArmCmmConfig.stated`); None: the simulation's own noise
    (for bounds computed from the truth)."""
    meas = sim.tracker(q_true, rng)
    if stated is None:
        sigma = sim.tracker_sigma(meas)
        enc = sim.truth.encoder_noise_urad * 1e-6
    else:
        (a, b), ang, enc = stated
        sigma = np.stack(
            [
                (a + b * meas[:, 0] / 1000) / 1000,
                np.full(len(meas), ang * 1e-6),
                np.full(len(meas), ang * 1e-6),
            ],
            axis=1,
        )
        enc = enc * 1e-6
    return TrackerProblem(chain, q_read, meas, sigma, enc if rng is not None else 0.0)


def check_cones(config: ArmCmmConfig) -> None:
    """Each cone is within the arm's reach (one seating found by the simulator's inverse
    kinematics, on a generator of its own: a run's draws stay the same), else one BadInput line,
    said before any work."""
    sim = ArmSim(config.arm, config.truth)
    for cone in (config.truth.cone_a_mm, config.truth.cone_b_mm):
        sim.postures_in_cone(np.asarray(cone, float), 1, np.random.default_rng(0))


@dataclasses.dataclass
class PosturePlan:
    """The postures planned on candidates before measuring (steps 1-2).

    candidates : (m, N) random postures, rad; chosen : (k,) the indices chosen greedily to
    maximise O1; random : (k,) as many random ones (the first k: the candidates are random);
    o1_chosen, o1_random : their observability index; names : the tracker problem's parameter
    names, in its columns' order.
    """

    candidates: np.ndarray
    chosen: np.ndarray
    random: np.ndarray
    o1_chosen: float
    o1_random: float
    names: tuple[str, ...]


def plan_postures(sim: ArmSim, chain: Chain, config: ArmCmmConfig, rng) -> PosturePlan:
    """The identifiable parameters (the whitened Jacobian at the start, by pivoted QR) and the
    ``n_postures`` of ``n_candidates`` random ones that maximise O1 for them."""
    candidates = sim.random_postures(config.n_candidates, rng)
    plan = tracker_problem(sim, chain, candidates, candidates, None)
    basis = identifiable_basis(plan)
    names = plan.names
    J = plan.jacobian(plan.start())[:, basis.kept] * parameter_scales(
        [names[k] for k in basis.kept]
    )
    blocks = J.reshape(len(candidates), 3, -1)
    chosen_idx = select_postures(blocks, config.n_postures)
    random_idx = np.arange(config.n_postures)  # candidates are random: the first n
    o1_chosen = observability_index(blocks[chosen_idx].reshape(-1, blocks.shape[2]))
    o1_random = observability_index(blocks[random_idx].reshape(-1, blocks.shape[2]))
    return PosturePlan(candidates, chosen_idx, random_idx, o1_chosen, o1_random, names)


@dataclasses.dataclass
class TrackerFit:
    """An identification from the tracker: its problem, the identification, its time (s)."""

    problem: TrackerProblem
    ident: Identification
    elapsed_s: float


def identify_from_tracker(
    sim: ArmSim, chain: Chain, q_true: np.ndarray, stated: tuple, rng
) -> TrackerFit:
    """Measure the arm at motor angles ``q_true`` (n, N) rad with the tracker (its encoders read
    with their noise) and identify its parameters, told the ``stated`` 1-sigma."""
    problem = tracker_problem(sim, chain, q_true, sim.encoders(q_true, rng), rng, stated)
    t0 = time.perf_counter()
    try:
        ident = identify_identifiable(problem)
    except np.linalg.LinAlgError:
        raise BadInput(
            f"the arm {sim.arm.name} leaves the identification singular: its links give the "
            "tool point too little motion to determine its parameters (an arm without length?)"
        ) from None
    return TrackerFit(problem, ident, time.perf_counter() - t0)


@dataclasses.dataclass
class HeldOut:
    """The held-out postures' probe positions in the tracker frame.

    q_true, q_read : (m, N) the motor angles and their encoder readings, rad.
    y_true : (m, 3) MuJoCo's positions, mm; y_before : (m, 3) the nominal model's, at the
    chosen fit's starting frame; R_bt, t_bt : the true base-to-tracker frame (3, 3), (3,) mm.
    """

    q_true: np.ndarray
    q_read: np.ndarray
    y_true: np.ndarray
    y_before: np.ndarray
    R_bt: np.ndarray
    t_bt: np.ndarray


def held_out_rms(chain: Chain, fits: dict[str, TrackerFit], held: HeldOut) -> dict[str, float]:
    """Probe RMS (mm) at the held-out postures, in the tracker frame (where the model's frame
    choices cancel): ``before`` (the nominal model) and each fit's."""
    rms = {"before": _rms(held.y_before - held.y_true)}
    for label, fit in fits.items():
        st = fit.ident.state
        rms[label] = _rms(point(chain, held.q_read, st.delta) @ st.R.T + st.t - held.y_true)
    return rms


def identify_from_cones(
    sim: ArmSim, chain: Chain, config: ArmCmmConfig, held: HeldOut, rng
) -> tuple[Identification, float]:
    """Identify the arm from single-point articulation in two cones of a bar alone; and the
    held-out postures' probe RMS (mm) after a rigid fit (the cones fix no base frame: shapes are
    compared)."""
    truth = config.truth
    cones = [np.asarray(truth.cone_a_mm), np.asarray(truth.cone_b_mm)]
    q_cone = np.vstack([sim.postures_in_cone(c, config.n_per_cone, rng) for c in cones])
    which = np.repeat([0, 1], config.n_per_cone)
    cone_problem = ConeProblem(
        chain,
        sim.encoders(q_cone, rng),
        which,
        config.cone_point_sigma_mm,
        truth.bar_length_mm,
        config.bar_sigma_mm,
    )
    cone_ident = identify_identifiable(cone_problem)
    p_cone = point(chain, held.q_read, cone_ident.state.delta)
    R_c, t_c = rigid_transform(p_cone, sim.probe_mm(held.q_true))
    return cone_ident, _rms(p_cone @ R_c.T + t_c - sim.probe_mm(held.q_true))


def run_checks(
    config: ArmCmmConfig,
    rms: dict[str, float],
    plan: PosturePlan,
    fits: dict[str, TrackerFit],
    cone_ident: Identification,
) -> list[Check]:
    """The run's checks: the held-out probe RMS before and after each identification, the
    chosen postures' observability against random ones, the dropped parameters, and that every
    solve converged."""
    ident = fits["chosen"].ident
    return [
        Check(
            "probe_rms_before_mm",
            rms["before"],
            None,
            note=f"{config.n_holdout} held-out postures, nominal model",
        ),
        Check(
            "probe_rms_after_mm",
            rms["chosen"],
            config.after_limit_mm,
            note="held-out postures, identified from the tracker at the chosen postures",
        ),
        Check(
            "probe_rms_after_random_mm", rms["random"], None, note="the same, from random postures"
        ),
        Check(
            "probe_rms_after_cone_mm",
            rms["cone"],
            None,
            note="identified from the cones and the bar alone; compared after a rigid fit (no "
            "base frame)",
        ),
        Check(
            "observability_chosen",
            plan.o1_chosen,
            None,
            note="O1 (Borm and Menq) of the chosen postures",
        ),
        Check("observability_random", plan.o1_random, None, note="O1 of as many random postures"),
        Check("observability_gain", plan.o1_chosen / plan.o1_random, 1.0, op=">="),
        Check(
            "dropped_parameters",
            float(len(ident.basis.dropped)),
            None,
            note="; ".join(f"{k}: {v}" for k, v in ident.basis.dropped.items()),
        ),
        # a solve that ran out of iterations would report its last iterate as if it were the answer
        Check(
            "solves_not_converged",
            float(sum(not f.ident.converged for f in fits.values()) + (not cone_ident.converged)),
            0.0,
            note="tracker (chosen and random postures), cones",
        ),
    ]


def run(config: ArmCmmConfig, seed: int, fidelity: str, out_dir: Path, rrd: bool) -> Report:
    """Simulate the arm CMM (any serial arm of an ARM.toml) measured by a laser tracker, cones and a
    length bar; calibrate it from what its sensors recorded; compare with the truth.

    The arguments and the Report: :class:`calibench.scenarios.registry.Scenario`.
    """
    # the arm's instruments are geometric: one fidelity (MuJoCo's kinematics plus sensor noise)
    rng = np.random.default_rng(seed)
    sim = ArmSim(config.arm, config.truth)
    chain = chain_of(sim.arm)
    # 1-2. identifiability and postures, planned on candidates before measuring
    plan = plan_postures(sim, chain, config, rng)
    # 3. identification from the tracker (the held-out postures drawn first)
    holdout = sim.random_postures(config.n_holdout, rng)
    q_hold = sim.encoders(holdout, rng)
    fits = {
        label: identify_from_tracker(sim, chain, plan.candidates[idx], config.stated, rng)
        for label, idx in (("chosen", plan.chosen), ("random", plan.random))
    }
    problem, ident = fits["chosen"].problem, fits["chosen"].ident
    reference = reference_values(sim.arm, sim.delta, list(ident.estimate), ident.basis.partners)
    # 4. held-out postures, in the tracker frame (where the model's frame choices cancel)
    R_bt, t_bt = sim.base2tracker()
    start = problem.start()
    y_true = sim.probe_mm(holdout) @ R_bt.T + t_bt
    y_before = point(chain, q_hold) @ start.R.T + start.t
    held = HeldOut(holdout, q_hold, y_true, y_before, R_bt, t_bt)
    rms = held_out_rms(chain, fits, held)
    # cones and a length bar alone
    cone_ident, rms["cone"] = identify_from_cones(sim, chain, config, held, rng)

    # no pixels here: the sensors are MuJoCo's geometry plus noise models, whatever was asked
    report = Report(scenario=NAME, seed=seed, fidelity="analytic")
    report.parameters, by_holdout = tracker_parameters(plan.names, ident, reference)
    report.checks += run_checks(config, rms, plan, fits, cone_ident)
    report.info = {
        # a time is the machine's, not a check: a loaded machine would fail a right result
        "identification_s": fits["chosen"].elapsed_s,
        "dropped_tracker": ident.basis.dropped,
        "dropped_cone": cone_ident.basis.dropped,
        "whitened_rms_tracker": ident.rms,
        "whitened_rms_cone": cone_ident.rms,
        "arm": sim.arm.name,
        "injected_delta": dict(zip(param_names(sim.n_joints), map(float, sim.delta))),
        # kept parameters with no independent reference (reference_values): the frames, and
        # errors that absorb others through the chain; the held-out positions judge them
        "judged_by_holdout": by_holdout,
        "cone_estimates": {k: v for k, v in cone_ident.estimate.items()},
        "observability_index": "O1 = (prod sigma_i)^(1/L) / sqrt(rows), columns scaled 0.1 mm / 1 "
        "mrad",
    }
    artifacts = dict(
        sim=sim,
        chain=chain,
        postures=plan.candidates[plan.chosen],
        problem=problem,
        ident=ident,
        start=start,
        holdout=holdout,
        y_true=y_true,
        y_before=y_before,
        R_bt=R_bt,
        t_bt=t_bt,
    )
    write_recording(out_dir, NAME, config, seed, report.info)
    return write_outputs(report, artifacts, out_dir, rrd, "calibench.scenarios.arm_cmm")


def _rms(d: np.ndarray) -> float:
    return float(np.sqrt(np.mean(np.sum(d * d, axis=1))))


def trial_parameters(config: ArmCmmConfig, seed: int) -> list[Parameter]:
    """The Monte-Carlo unit: tracker identification at ``n_postures`` random postures, each kept
    parameter that has one against its independent reference (:func:`reference_values`; no
    planning, no cones, no figures)."""
    rng = np.random.default_rng(seed)
    sim = ArmSim(
        config.arm, config.truth, reuse=True
    )  # the trial's alone: the last trial's model rewritten
    chain = chain_of(sim.arm)
    q = sim.random_postures(config.n_postures, rng)
    q_read = sim.encoders(q, rng)
    noisy = tracker_problem(sim, chain, q, q_read, rng, config.stated)
    ident = identify_identifiable(noisy)
    # the Cramer-Rao bound: the Jacobian at the truth (the injected errors, the tracker's true
    # frame) whitened by the simulation's own noise (tracker and encoders), not the datasheet's,
    # unscaled by any residual; the dropped columns stay at their true values
    true_noise = noisy.reweighted(
        sim.tracker_sigma(noisy.meas), sim.truth.encoder_noise_urad * 1e-6
    )
    R_bt, t_bt = sim.base2tracker()
    J = true_noise.jacobian(TrackerState(sim.delta, R_bt, t_bt))[:, ident.basis.kept]
    crlb2 = np.diag(np.linalg.inv(J.T @ J))
    if not np.all(crlb2 >= 0):
        raise np.linalg.LinAlgError("the bound's normal matrix is singular to working precision")
    crlb = np.sqrt(crlb2)
    names = noisy.names
    bound = {names[j]: crlb[i] for i, j in enumerate(ident.basis.kept)}
    reference = reference_values(sim.arm, sim.delta, list(ident.estimate), ident.basis.partners)
    out = []
    for name in ident.estimate:
        if name not in reference:
            continue
        f = 1e6 if is_angle(name) else 1.0
        out.append(
            Parameter(
                name,
                "urad" if f > 1 else "mm",
                reference[name] * f,
                ident.estimate[name] * f,
                ident.std[name] * f,
                TOL_SIGMA * ident.std[name] * f,
                crlb=bound[name] * f,
            )
        )
    return out


def prior(config: ArmCmmConfig, rng: np.random.Generator) -> ArmCmmConfig:
    """Each error drawn as N(0, |the default truth's value|) (Table 1 for the seed's arm): mm and
    rad."""
    from calibench.scenes.arm_cmm import load_arm
    from calibench.sim.arm_cmm import default_errors

    # the description read once, here, for the whole trial (not again by each simulator)
    arm = load_arm(config.arm) if isinstance(config.arm, str) else config.arm
    scale = np.abs(np.asarray(config.truth.delta or default_errors(arm), float))
    return dataclasses.replace(
        config, arm=arm, truth=dataclasses.replace(config.truth, delta=tuple(rng.normal(0, scale)))
    )
