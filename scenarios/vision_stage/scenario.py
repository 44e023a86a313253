"""Scenario ``vision-stage``: compensate a vision measuring machine's table with a circle plate.

The seed paper's procedure, end to end:

1. Align the plate: servo circle (0, 0), then a far circle of the same row, to the image centre;
   the angle of the line between them against X is phi. The operator turns the plate by -phi
   and checks again until phi is within tolerance (the rotate-and-check loop).
2. Point pairs: servo each of the 20 x 13 circles within the travel to within 0.5 px of the
   image centre and record the scale readings against the plate's nominal grid (turned by the
   last measured phi). The residual offset, measured in the same image, is added to the reading.
   Rendered, each circle is first aimed where the circles before it predict it (one look, not
   two, for most).
3. Compensation models side by side: (a) line rulers along X and Y (Eq. 3-4), (b) the cubic
   bivariate polynomial (Eq. 5-9), (c) a polynomial whose degree is chosen by cross-validation.
4. Verification: a laser interferometer along lines in X and in Y at three offsets each,
   bidirectional, 5 runs, evaluated with ISO 230-2, without and with each compensation.

Fidelity ``render``: microscope images from MuJoCo and the circle detector; ``analytic``: the
exact image of each centre plus the detector's noise.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from calibench.estimators.stage.circle_plate import PlateFit, compensation_models, fit_plate
from calibench.estimators.stage.compensation import MODEL_DEGREES, fit_polynomial
from calibench.scenarios.harness import write_outputs
from calibench.scenarios.report import Check, Parameter, Report, progress
from calibench.scenarios.run_recording import StageRecordingPlan, check_plan, write_recording
from calibench.scenarios.vision_stage import NAME
from calibench.scenarios.vision_stage.procedure import (
    RULER_SHORTER_BY_MM,
    Microscope,
    align_plate,
    interferometer_lines,
    interferometer_test,
    measure_rulers,
    predicted_correction,
    servo,
)
from calibench.scenes.vision_stage import VisionStageGeometry
from calibench.sim.vision_stage import VisionStageSim, VisionStageTruth

TOL_SIGMA = 5.0


@dataclasses.dataclass(frozen=True)
class VisionStageConfig:
    geometry: VisionStageGeometry = VisionStageGeometry()
    truth: VisionStageTruth = VisionStageTruth()
    pixel_noise_dn: float = 2.0  # sensor noise, grey levels
    psf_px: float = 1.0  # optics' blur, 1-sigma px
    centre_noise_px: float = (
        0.0013  # analytic fidelity: detector noise per axis (renders: 0.0018 px RMS 2-D)
    )
    grid: tuple[int, int] = (20, 13)  # circles measured along X and Y
    servo_tolerance_px: float = 0.5
    align_tolerance_urad: float = 4.0
    align_max_turns: int = 6
    turn_error: float = 0.1  # the operator's turn is off by this fraction of the turn ...
    turn_noise_urad: float = 2.0  # ... plus this scatter
    ruler_pitch_mm: float = 10.0
    ruler_parallelism_urad: float = 150.0  # the ruler's angle to the axis it calibrates
    ruler_aim_um: float = 0.8  # scatter of the operator's aim at a graduation, by eye at 10 um/px
    ruler_error_um: float = 1.0  # graduation error, 1-sigma (a +-2 um class ruler)
    x_lines_at_y_mm: tuple[float, ...] = (20.0, 100.0, 180.0)
    y_lines_at_x_mm: tuple[float, ...] = (20.0, 150.0, 280.0)
    targets_per_line: int = 11
    runs: int = 5
    interferometer_noise_um: float = 0.05
    centre_limit_px: float = 0.1
    phi_limit_urad: float = 10.0
    lineruler_limit_um: float = 8.0
    polynomial_limit_um: float = 3.0

    # [vision-stage.recording]: what DIR/recording.csv records and conceals (run_recording.py)
    recording: StageRecordingPlan = StageRecordingPlan(step_mm=4.5)

    def __post_init__(self):
        check_plan(NAME, self.recording, self.geometry.travel_mm)
        check_config(self)


# What the config's checks hold the set-up to (see check_config).
MAX_SQUARENESS_RAD = (
    0.01  # 10 mm per metre: beyond it the axes are not square, not slightly out of square
)
MAX_TURN_ERROR = (
    0.5  # the operator's turn off by half of it at 1 sigma: the rotate-and-check loop still closes
)
MIN_RULER_PITCH_MM = (
    1.0  # graduations far apart beside the aim's scatter (um), so their readings increase
)
MAX_RULER_SCATTER = (
    0.1  # the aim's and the graduations' 1-sigma, of the pitch: the readings stay in order
)


def check_config(c: VisionStageConfig) -> None:
    """What makes a vision-stage set-up workable, checked before any simulation (BadInput, one
    line naming the key): a microscope whose field holds one circle, a grid of circles on the plate
    and in the travel with enough circles for the models, interferometer lines over the calibrated
    range, a ruler with graduations, and errors that are errors."""
    from calibench.scenarios.config import bad, check_camera

    g = c.geometry
    cam, plate = g.camera, g.plate
    check_camera(cam, f"{NAME}.geometry.camera")
    # the microscope's field must hold a whole circle, and not two of them
    field = np.array([cam.width / cam.fx, cam.height / cam.fy]) * g.working_distance_mm
    lo = plate.diameter_mm / min(cam.width / cam.fx, cam.height / cam.fy)
    hi = (plate.pitch_mm + plate.diameter_mm) / max(cam.width / cam.fx, cam.height / cam.fy)
    if not lo < g.working_distance_mm < hi:
        raise bad(
            f"{NAME}.geometry.working_distance_mm",
            g.working_distance_mm,
            f"the microscope sees {field[0]:.3g} x {field[1]:.3g} mm; its field must hold one "
            f"whole {plate.diameter_mm:g} mm circle and not two ({plate.pitch_mm:g} mm pitch): "
            f"working_distance_mm from {lo:.4g} to {hi:.4g} with this camera",
        )
    if plate.diameter_mm >= plate.pitch_mm:
        raise bad(
            f"{NAME}.geometry.plate.diameter_mm",
            plate.diameter_mm,
            f"the circles must stand apart: a diameter below the pitch ({plate.pitch_mm:g} mm)",
        )
    # the grid: on the plate, in the travel, and enough circles along each axis for every model
    # the scenario fits (select_model's polynomial degrees up to its largest need one circle more)
    need = max(max(MODEL_DEGREES), 3) + 1
    for axis, n in enumerate(c.grid):
        room = int((g.travel_mm[axis] - g.plate_origin_reading_mm[axis]) // plate.pitch_mm) + 1
        most = min(plate.n, room)
        if not need <= n <= most:
            raise bad(
                f"{NAME}.grid",
                c.grid,
                f"from {need} to {most} circles along {'XY'[axis]} ({need}: the model selection "
                "fits "
                f"polynomials up to degree {need - 1}, which need {need} along each axis; {most}: "
                f"the plate's {plate.n} x {plate.n} circles at {plate.pitch_mm:g} mm within the "
                f"{g.travel_mm[axis]:g} mm travel)",
            )
    # interferometer lines: at least one each way, over the range the plate calibrated
    for axis, key in ((1, "x_lines_at_y_mm"), (0, "y_lines_at_x_mm")):
        at = np.asarray(getattr(c, key), float)
        lo = g.plate_origin_reading_mm[axis]
        hi = lo + (c.grid[axis] - 1) * plate.pitch_mm
        if len(at) == 0 or not np.all((at >= lo) & (at <= hi)):
            raise bad(
                f"{NAME}.{key}",
                getattr(c, key),
                f"one line or more, each over the range the grid calibrates: {'XY'[axis]} from "
                f"{lo:g} to {hi:g} mm (a model is not tested where it extrapolates)",
            )
    # the line rulers: graduations far enough apart to read in order, two or more on each axis
    longest = min(g.travel_mm) - RULER_SHORTER_BY_MM
    if not MIN_RULER_PITCH_MM <= c.ruler_pitch_mm <= longest:
        raise bad(
            f"{NAME}.ruler_pitch_mm",
            c.ruler_pitch_mm,
            f"from {MIN_RULER_PITCH_MM:g} mm (graduations read in order through the aim's "
            "scatter) to "
            f"{longest:g} mm (two graduations on the {longest:g} mm ruler of the shorter axis)",
        )
    for key in ("ruler_aim_um", "ruler_error_um"):
        if getattr(c, key) / 1000 > MAX_RULER_SCATTER * c.ruler_pitch_mm:
            raise bad(
                f"{NAME}.{key}",
                getattr(c, key),
                "a graduation's scatter is a small part of the pitch: at most "
                f"{MAX_RULER_SCATTER:.0%} of ruler_pitch_mm = {c.ruler_pitch_mm:g}, "
                f"{MAX_RULER_SCATTER * c.ruler_pitch_mm * 1000:g} um",
            )
    if not 0 <= c.turn_error <= MAX_TURN_ERROR:
        raise bad(
            f"{NAME}.turn_error",
            c.turn_error,
            f"the fraction the operator's turn is off by: from 0 to {MAX_TURN_ERROR:g} (at 1 or "
            f"more the rotate-and-check loop does not converge)",
        )
    s = c.truth.squareness_rad
    if not abs(s) <= MAX_SQUARENESS_RAD:
        raise bad(
            f"{NAME}.truth.squareness_rad",
            s,
            f"a squareness error is a small angle: from -{MAX_SQUARENESS_RAD:g} to "
            f"{MAX_SQUARENESS_RAD:g} rad ({MAX_SQUARENESS_RAD * 1000:g} mm per metre)",
        )


def run(config: VisionStageConfig, seed: int, fidelity: str, out_dir: Path, rrd: bool) -> Report:
    """Simulate the vision measuring machine's table under its microscope, with a circle plate
    and an interferometer; calibrate it from what its sensors recorded; compare with the truth.

    The arguments and the Report: :class:`calibench.scenarios.registry.Scenario`.
    """
    rng = np.random.default_rng(seed)
    g = config.geometry
    sim = VisionStageSim(
        g, config.truth, np.random.default_rng(rng.integers(2**63)), render=fidelity == "render"
    )
    scope = Microscope(sim, config, fidelity, windowed=out_dir is None)
    try:
        # 1. alignment ---------------------------------------------------------------------------
        phi_est, phi_true, s00 = align_plate(sim, scope, config, rng)
        phi_final = phi_est[-1]
        phi_residual = phi_true[-1]

        # 2. point pairs -------------------------------------------------------------------------
        # a rendered look costs a frame, so each circle is aimed where its neighbours predict it
        # and one look usually settles it; the analytic look is free and keeps the draws its
        # results were made with
        nominal_machine, readings, images = point_pairs(
            sim, scope, config, s00, phi_final, fidelity == "render", shown=True
        )

        # 3. models ------------------------------------------------------------------------------
        nx, pitch = config.grid[0], g.plate.pitch_mm
        plate = fit_plate(readings, nominal_machine, (nx - 1) * pitch)
        rulers = measure_rulers(sim, config, rng, s00)

        # truth for the coefficients: the same cubic fitted to the true error field at the
        # same readings, in the frame the alignment defines (X along the X motion)
        true_err = true_error_field(sim, readings, phi_residual)
        u, v = plate.u_mm, plate.v_mm
        cubic_true = [fit_polynomial(u, v, true_err[:, a], 3) for a in range(2)]

        # 4. verification ------------------------------------------------------------------------
        models = compensation_models(plate, rulers)
        lines = interferometer_lines(config, rng)
        verification = {
            name: interferometer_test(sim, config, lines, model) for name, model in models.items()
        }

        report = build_report(
            config,
            seed,
            fidelity,
            scope,
            phi_est,
            phi_true,
            phi_residual,
            plate,
            cubic_true,
            verification,
        )
        report.info["microscope_looks"] = len(scope.errors_px)  # images, when rendered
        if sim.renderer is not None:  # a GPU's name, or llvmpipe's: frames made on the CPU
            report.info["renderer"] = sim.renderer.gl_renderer
        artifacts = dict(
            sim=sim,
            readings=readings,
            err_um=plate.err_um,
            true_err=true_err,
            models=models,
            verification=verification,
            images=images,
            s00=s00,
            geometry=g,
        )
        write_recording(out_dir, NAME, config, seed, report.info)
        return write_outputs(report, artifacts, out_dir, rrd, "calibench.scenarios.vision_stage")
    finally:
        sim.close()


def point_pairs(
    sim: VisionStageSim,
    scope: Microscope,
    config: VisionStageConfig,
    s00: np.ndarray,
    phi_rad: float,
    aimed: bool,
    shown: bool = False,
) -> tuple[np.ndarray, np.ndarray, list[tuple]]:
    """Servo each circle of the grid to the image centre (the seed's step 2), row by row.

    Parameters
    ----------
    sim, scope : the machine and its microscope.
    config : the set-up (its ``grid`` and ``servo_tolerance_px``).
    s00 : (2,) the reading of circle (0, 0) from the alignment, mm.
    phi_rad : the plate's measured angle: the nominal grid is turned by it.
    aimed : aim each circle where the circles before it predict it
        (:func:`~.procedure.predicted_correction`), else at its nominal place.
    shown : report each circle to the command's progress line.

    Returns
    -------
    nominal_mm : (n, 2) each circle's nominal place from circle (0, 0), turned by ``phi_rad``.
    readings_mm : (n, 2) the reading at which each circle is on the optical axis.
    images : (k, image, found, true) of the grid's four corner circles, when rendered.
    """
    nx, ny = config.grid
    j, i = np.mgrid[0:ny, 0:nx]
    nominal = np.stack([i.ravel(), j.ravel()], axis=1) * config.geometry.plate.pitch_mm
    c, s = np.cos(phi_rad), np.sin(phi_rad)
    nominal_machine = nominal @ np.array([[c, s], [-s, c]])  # turned by phi
    readings = np.empty_like(nominal_machine)
    aim = predicted_correction if aimed else (lambda *_: 0.0)
    images: list[tuple] = []
    circles = enumerate(nominal_machine)
    for k, p in progress(circles, "circles", len(nominal_machine)) if shown else circles:
        lead = aim(readings[:k] - s00 - nominal_machine[:k], k, nx)
        readings[k], _ = servo(sim, scope, s00 + p + lead, config.servo_tolerance_px)
        if scope.last_image is not None and k % nx in (0, nx - 1) and k // nx in (0, ny - 1):
            images.append((k, scope.last_image, scope.last_found, scope.last_true))
    return nominal_machine, readings, images


def true_error_field(sim: VisionStageSim, readings: np.ndarray, phi_residual: float) -> np.ndarray:
    """True - reading (um) at the readings, relative to the first, in the frame whose x runs
    along the X motion (the plate's frame turned back by its true residual angle)."""
    p = np.array([sim.true_point_mm(r[0], r[1], body="plate") for r in readings])
    c, s = np.cos(phi_residual), np.sin(phi_residual)
    p = p @ np.array([[c, s], [-s, c]])
    return ((p - p[0]) - (readings - readings[0])) * 1000


def build_report(
    config,
    seed,
    fidelity,
    scope,
    phi_est,
    phi_true,
    phi_residual,
    plate: PlateFit,
    cubic_true,
    verification,
) -> Report:
    """The vision stage's Report: phi, the cubic's coefficients against the truth, the ISO 230-2
    checks."""
    report = Report(scenario=NAME, seed=seed, fidelity=fidelity)
    report.parameters.append(
        Parameter(
            "phi_urad",
            "urad",
            phi_true[0] * 1e6,
            phi_est[0] * 1e6,
            plate.phi_std_rad * 1e6,
            tolerance=TOL_SIGMA * plate.phi_std_rad * 1e6,
        )
    )
    cubic, selected = plate.cubic, list(zip(plate.best, plate.cv_rms_um))
    for a, axis in enumerate("xy"):
        std = plate.cubic_std[a]
        for k in range(10):
            unit = "um" if k == 0 else f"um/mm^{[0, 1, 1, 2, 2, 2, 3, 3, 3, 3][k]}"
            report.parameters.append(
                Parameter(
                    f"e{axis}_a{k}",
                    unit,
                    float(cubic_true[a].coef[k]),
                    float(cubic[a].coef[k]),
                    float(std[k]),
                    tolerance=TOL_SIGMA * float(std[k]),
                )
            )
    errs = np.array(scope.errors_px)
    worst = {
        name: max(
            float(np.max(np.abs(np.r_[ln["dev_up_um"].ravel(), ln["dev_down_um"].ravel()])))
            for ln in lines
        )
        for name, lines in verification.items()
    }
    report.checks += [
        Check(
            "circle_centre_rms_px",
            float(np.sqrt(np.mean(np.sum(errs**2, axis=1)))),
            config.centre_limit_px,
            note="detected vs exact image of the circle's centre, every measurement",
        ),
        Check(
            "phi_residual_urad",
            abs(phi_residual) * 1e6,
            config.phi_limit_urad,
            note=f"plate's true angle to the X motion after {len(phi_est) - 1} turn(s)",
        ),
        Check(
            "pos_error_uncompensated_um",
            worst["uncompensated"],
            None,
            note="largest |positioning deviation|, interferometer, both axes, all lines and runs",
        ),
        Check("pos_error_lineruler_um", worst["lineruler"], config.lineruler_limit_um),
        Check("pos_error_polynomial_um", worst["polynomial"], config.polynomial_limit_um),
        Check(
            "pos_error_best_um",
            worst["best"],
            config.polynomial_limit_um,
            note=f"X: {selected[0][0].name}; Y: {selected[1][0].name}; chosen by 10-fold CV",
        ),
    ]
    for axis in "xy":
        lines = [ln for ln in verification["polynomial"] if ln["axis"] == axis]
        for fig in ("A", "B"):
            value = max(ln["iso"].as_dict()[fig] for ln in lines)
            report.checks.append(
                Check(
                    f"iso_{fig}_{axis}_um",
                    value,
                    None,
                    note="ISO 230-2, polynomial compensation, worst line",
                )
            )
    report.info = {
        "phi_estimates_urad": [p * 1e6 for p in phi_est],
        "phi_truths_urad": [p * 1e6 for p in phi_true],
        "point_scatter_um": plate.sigma_um,
        "best_model": {axis: selected[a][0].name for a, axis in enumerate("xy")},
        "cv_rms_um": {
            axis: {k: v for k, v in selected[a][1].items() if "period" not in k}
            | {"best periodic": min(v for k, v in selected[a][1].items() if "period" in k)}
            for a, axis in enumerate("xy")
        },
        "iso230_2": {
            name: [
                {"axis": ln["axis"], "at_mm": ln["at_mm"], **ln["iso"].as_dict()} for ln in lines
            ]
            for name, lines in verification.items()
        },
        "worst_deviation_um": worst,
    }
    return report


def prior(config: VisionStageConfig, rng: np.random.Generator) -> VisionStageConfig:
    """The plate laid at phi uniform in 0.5-2.5 mrad; the machine's errors as configured."""
    truth = dataclasses.replace(config.truth, plate_phi_rad=float(rng.uniform(0.5e-3, 2.5e-3)))
    return dataclasses.replace(config, truth=truth)
