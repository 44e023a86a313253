"""Scenario ``probe-scanner``: calibrate a frame tracer's rail with a square plate, trace a rim.

1. One turn over the calibration plate (1600 samples).
2. The seed paper's method: quadratic fits over m samples around the four minima, d, dL and
   alpha0 in closed form; swept over m = 5..100 on this turn, and over 20 fresh turns to find
   the range of m whose error stays within the 0.5 mm requirement; the chosen m is 50.
3. The full-data method: least squares of (d, dL, alpha0, plate centre) on all 1600 samples.
4. One turn around a spectacle rim, reconstructed with the design values (before) and with each
   calibration (after), against the rim's true outline.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from calibench.estimators.probe_scanner.calibration import (
    ScannerCalibration,
    calibrate_lsq,
    calibrate_paper,
    contour_points,
    fit_minima,
    paper_sweep_d_mm,
)
from calibench.scenarios.harness import write_outputs
from calibench.scenarios.probe_scanner import NAME
from calibench.scenarios.report import Check, Parameter, Report
from calibench.scenarios.run_recording import ScannerRecordingPlan, check_plan, write_recording
from calibench.scenes.probe_scanner import ProbeScannerGeometry, ProbeScannerNominal
from calibench.sim.probe_scanner import ProbeScannerSim, ProbeScannerTruth

TOL_SIGMA = 5.0


@dataclasses.dataclass(frozen=True)
class ProbeScannerConfig:
    geometry: ProbeScannerGeometry = ProbeScannerGeometry()
    truth: ProbeScannerTruth = ProbeScannerTruth()
    nominal: ProbeScannerNominal = ProbeScannerNominal()
    paper_m: int = 50
    m_sweep: tuple[int, int, int] = (5, 101, 1)  # range(start, stop, step)
    sweep_turns: int = 20
    d_requirement_mm: float = 0.5  # the system requirement on d (and on dL)
    contour_quanta: float = 3.0  # "after" must be within this many encoder quanta

    # [probe-scanner.recording]: what DIR/recording.csv records and conceals (run_recording.py)
    recording: ScannerRecordingPlan = ScannerRecordingPlan()

    def __post_init__(self):
        check_plan(NAME, self.recording)
        check_config(self)


def check_config(c: ProbeScannerConfig) -> None:
    """What makes a probe-scanner set-up workable, checked before any simulation (BadInput, one
    line naming the key): a rail whose stylus starts inside both openings, a plate whose sides stay
    flat where the paper's fits look, and windows the quadratic fits can take."""
    from calibench.scenarios.config import bad, show
    from calibench.scenarios.report import BadInput

    g, t = c.geometry, c.truth
    a, r = g.plate.half_side_mm, g.plate.corner_radius_mm
    # the estimators' convention (probe_scanner.calibration): d > 0 by the mechanism's construction
    if not t.d_mm > 0:
        raise bad(
            f"{NAME}.truth.d_mm",
            t.d_mm,
            "the rail's offset from the table's axis is positive by the "
            "mechanism's construction (the estimators take that branch)",
        )
    # the stylus starts at Q, hypot(d, dL) from the table's axis, and must find a wall all round
    q = float(np.hypot(t.d_mm, t.dL_mm))
    plate_room = a - float(np.hypot(*t.plate_centre_mm))
    rim_room = float(np.min(np.linalg.norm(g.lens.outline(n=4000), axis=1)))
    if not q < min(plate_room, rim_room):
        raise BadInput(
            f"config: {NAME}.truth.d_mm = {show(t.d_mm)} (with dL_mm = {show(t.dL_mm)}): the "
            "stylus starts "
            f"{q:.4g} mm from the table's axis and must start inside both openings all round: "
            f"hypot(d_mm, dL_mm) below {min(plate_room, rim_room):.4g} mm (the plate's opening "
            f"leaves {plate_room:.4g} mm, the rim's {rim_room:.4g} mm)"
        )
    # the quadratic fits around the four minima: 3 to a quarter turn of samples (fit_minima)
    n = g.samples_per_turn
    ms = np.arange(*c.m_sweep) if c.m_sweep[2] != 0 else np.empty(0)  # a step of 0: no range
    if len(ms) == 0 or ms.min() < 3 or ms.max() > n // 4:
        raise bad(
            f"{NAME}.m_sweep",
            c.m_sweep,
            f"range(start, stop, step) of window sizes m from 3 to {n // 4} "
            f"(a quarter of the {n} samples of a turn), not empty",
        )
    if not 3 <= c.paper_m <= n // 4:
        raise bad(
            f"{NAME}.paper_m",
            c.paper_m,
            f"from 3 to {n // 4} samples (a quarter of the {n} of a turn)",
        )
    # each side's minimum lies at its middle; the widest window reaches along the side to
    # (d + a sin phi) / cos phi at phi* +- its half-width (sin phi* = -d / a): the side must be
    # flat there, or the paper's fits see the corner (and a radius of a or more is no square)
    if t.d_mm < a:
        half = (max(int(ms.max()), c.paper_m) / 2) / n * 2 * np.pi
        phi = np.arcsin(-t.d_mm / a) + np.array([-half, half])
        reach = float(np.max(np.abs((t.d_mm + a * np.sin(phi)) / np.cos(phi)))) + float(
            np.hypot(*t.plate_centre_mm)
        )
        if not r < a - reach:
            raise bad(
                f"{NAME}.geometry.plate.corner_radius_mm",
                r,
                "the plate's sides must be flat where the fits around their middles look "
                f"({reach:.3g} mm each "
                f"side of the middle): corner_radius_mm from 0 to below {a - reach:.4g} mm with "
                f"half_side_mm = {a:g}",
            )


def run(config: ProbeScannerConfig, seed: int, fidelity: str, out_dir: Path, rrd: bool) -> Report:
    """Simulate the rotary probe scanner tracing its calibration opening and a spectacle rim;
    calibrate it from what its sensors recorded; compare with the truth.

    The arguments and the Report: :class:`calibench.scenarios.registry.Scenario`.
    """
    # the probe's physics has one fidelity: MuJoCo's ray plus the sensor model
    rng = np.random.default_rng(seed)
    g, truth, nom = config.geometry, config.truth, config.nominal
    sim = ProbeScannerSim(g, truth)
    a, r = g.plate.half_side_mm, g.plate.corner_radius_mm

    plate, _ = sim.scan("plate", rng)
    ms = np.arange(*config.m_sweep)
    sweep = paper_sweep_d_mm(plate.theta_rad, plate.rho_mm, ms, a)
    turns = [sim.scan("plate", rng)[0] for _ in range(config.sweep_turns)]
    sweep_turns = np.array([paper_sweep_d_mm(t.theta_rad, t.rho_mm, ms, a) for t in turns])
    rms_m = np.sqrt(np.mean((sweep_turns - truth.d_mm) ** 2, axis=0))
    stable = ms[rms_m <= config.d_requirement_mm]

    paper = calibrate_paper(plate.theta_rad, plate.rho_mm, config.paper_m, a, nom.alpha0_rad)
    spread = paper_spread(turns, config.paper_m, a, nom.alpha0_rad)
    lsq = calibrate_lsq(plate.theta_rad, plate.rho_mm, a, r, paper)
    minima = fit_minima(plate.theta_rad, plate.rho_mm, config.paper_m)

    lens, _ = sim.scan("lens", rng)
    outline = sim.true_outline_mm("lens")
    contours = {
        "before": contour_points(lens.theta_rad, lens.rho_mm, nom.d_mm, nom.dL_mm, nom.alpha0_rad),
        "paper": contour_points(
            lens.theta_rad, lens.rho_mm, paper.d_mm, paper.dL_mm, paper.alpha0_rad
        ),
        "after": contour_points(lens.theta_rad, lens.rho_mm, lsq.d_mm, lsq.dL_mm, lsq.alpha0_rad),
    }
    rms = {
        k: float(np.sqrt(np.mean(sim.distance_to_outline_mm("lens", p) ** 2)))
        for k, p in contours.items()
    }

    # no pixels here: the sensors are MuJoCo's geometry plus noise models, whatever was asked
    report = Report(scenario=NAME, seed=seed, fidelity="analytic")
    req = config.d_requirement_mm
    report.parameters += calibration_parameters(truth, paper, lsq, spread)
    quantum = truth.quantum_um / 1000
    report.checks += [
        Check(
            "contour_rms_before_mm", rms["before"], None, note="rim traced with the design values"
        ),
        Check(
            "contour_rms_after_mm",
            rms["after"],
            config.contour_quanta * quantum,
            note=f"rim traced with the full-data calibration; limit {config.contour_quanta:g} "
            "encoder quanta",
        ),
        Check(
            "contour_rms_paper_mm",
            rms["paper"],
            None,
            note=f"rim traced with the paper's method, m = {config.paper_m}",
        ),
        Check("paper_m", float(config.paper_m), None, note="the m used for the *_paper parameters"),
    ]
    report.info = {
        "m_meeting_requirement_this_turn": _ranges(ms[np.abs(sweep - truth.d_mm) <= req]),
        "m_meeting_requirement_rms_over_turns": _ranges(stable),
        "requirement_mm": req,
        "sweep": {"m": ms, "d_mm": sweep, "rms_over_turns_mm": rms_m},
        "lsq_rms_residual_mm": lsq.rms_mm,
        "minima": [dataclasses.asdict(f) for f in minima],
    }
    artifacts = {
        "sim": sim,
        "plate": plate,
        "lens": lens,
        "contours_plate": contour_points(
            plate.theta_rad, plate.rho_mm, lsq.d_mm, lsq.dL_mm, lsq.alpha0_rad
        ),
        "ms": ms,
        "sweep": sweep,
        "rms_m": rms_m,
        "minima": minima,
        "contours": contours,
        "outline": outline,
        "config": config,
        "paper": paper,
        "lsq": lsq,
        "plate_outline": sim.true_outline_mm("plate"),
    }
    write_recording(out_dir, NAME, config, seed, report.info)
    return write_outputs(report, artifacts, out_dir, rrd, "calibench.scenarios.probe_scanner")


def paper_spread(
    turns: list, m: int, half_side_mm: float, alpha0_nominal_rad: float
) -> dict[str, float]:
    """The paper's method's 1-sigma from repeated turns: the scatter (ddof 1) of its d_mm,
    dL_mm and alpha0_rad over ``turns`` (fresh turns of the plate, each a ProbeScan), with
    window ``m``. The method states no uncertainty of its own; a turn repeated is how its user
    finds it (the seed paper's own sensitivity study over m)."""
    fits = [
        calibrate_paper(t.theta_rad, t.rho_mm, m, half_side_mm, alpha0_nominal_rad) for t in turns
    ]
    alpha0 = np.array([f.alpha0_rad for f in fits])
    alpha0 = np.angle(np.exp(1j * (alpha0 - alpha0[0]))) + alpha0[0]  # on one branch
    return {
        "d_mm": float(np.std([f.d_mm for f in fits], ddof=1)),
        "dL_mm": float(np.std([f.dL_mm for f in fits], ddof=1)),
        "alpha0_rad": float(np.std(alpha0, ddof=1)),
    }


def calibration_parameters(
    truth: ProbeScannerTruth,
    paper: ScannerCalibration,
    lsq: ScannerCalibration,
    paper_std: dict[str, float],
) -> list[Parameter]:
    """The rail's parameters by the paper's method and by the full data's least squares (d,
    dL, alpha0 and the plate's centre), against the ``truth``, each to TOL_SIGMA of its std:
    the least squares' own, the paper's method's ``paper_std`` (:func:`paper_spread`)."""
    # Not the 0.5 mm requirement on every turn: on one turn the method's d scatters 0.31 mm
    # (bias +0.12 mm) at m = 50, so a requirement of 1.6 sigma failed 1 seed in 8 (alpha0, its
    # error d's through asin(d / a), 1 in 6); the seed paper's requirement holds for the RMS
    # over turns (the sweep's, in report.info), and the method's scatter is what a turn is
    # judged by (200 seeds: at most 4.3 sigma)
    ps = paper_std
    out = [
        Parameter("d_paper", "mm", truth.d_mm, paper.d_mm, ps["d_mm"], TOL_SIGMA * ps["d_mm"]),
        Parameter("dL_paper", "mm", truth.dL_mm, paper.dL_mm, ps["dL_mm"], TOL_SIGMA * ps["dL_mm"]),
        Parameter(
            "alpha0_paper",
            "mrad",
            truth.alpha0_rad * 1e3,
            paper.alpha0_rad * 1e3,
            ps["alpha0_rad"] * 1e3,
            TOL_SIGMA * ps["alpha0_rad"] * 1e3,
        ),
    ]
    s = lsq.std
    if s is None:  # calibrate_lsq always states its std
        raise ValueError("the full-data calibration came without its std")
    out += [
        Parameter("d_lsq", "mm", truth.d_mm, lsq.d_mm, s["d_mm"], TOL_SIGMA * s["d_mm"]),
        Parameter("dL_lsq", "mm", truth.dL_mm, lsq.dL_mm, s["dL_mm"], TOL_SIGMA * s["dL_mm"]),
        Parameter(
            "alpha0_lsq",
            "mrad",
            truth.alpha0_rad * 1e3,
            lsq.alpha0_rad * 1e3,
            s["alpha0_rad"] * 1e3,
            TOL_SIGMA * s["alpha0_rad"] * 1e3,
        ),
        Parameter(
            "plate_cx_lsq",
            "mm",
            truth.plate_centre_mm[0],
            lsq.centre_mm[0],
            s["cx_mm"],
            TOL_SIGMA * s["cx_mm"],
        ),
        Parameter(
            "plate_cy_lsq",
            "mm",
            truth.plate_centre_mm[1],
            lsq.centre_mm[1],
            s["cy_mm"],
            TOL_SIGMA * s["cy_mm"],
        ),
    ]
    return out


def _ranges(ms: np.ndarray) -> list[list[int]]:
    """Consecutive runs of m, [[first, last], ...]."""
    out: list[list[int]] = []
    for m in np.asarray(ms, int):
        if out and m == out[-1][1] + 1:
            out[-1][1] = int(m)
        else:
            out.append([int(m), int(m)])
    return out


def prior(config: ProbeScannerConfig, rng: np.random.Generator) -> ProbeScannerConfig:
    """d uniform 6-10 mm, dL 2-4 mm, alpha0 0.25-0.45 rad, plate centre N(0, 0.15 mm) each axis."""
    truth = dataclasses.replace(
        config.truth,
        d_mm=float(rng.uniform(6, 10)),
        dL_mm=float(rng.uniform(2, 4)),
        alpha0_rad=float(rng.uniform(0.25, 0.45)),
        plate_centre_mm=tuple(rng.normal(0, 0.15, 2)),
    )
    return dataclasses.replace(config, truth=truth)
