"""Scenario ``vision-stage``: compensate a vision measuring machine's table with a circle plate.

The seed paper's procedure, end to end:

1. Align the plate: servo circle (0, 0), then a far circle of the same row, to the image centre;
   the angle of the line between them against X is phi. The operator turns the plate by -phi
   and checks again until phi is within tolerance (the rotate-and-check loop).
2. Point pairs: servo each of the 20 x 13 circles within the travel to within 0.5 px of the
   image centre and record the scale readings against the plate's nominal grid (turned by the
   last measured phi). The residual offset, measured in the same image, is added to the reading.
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

from calibench.estimators.camera.circles import find_dark_circle
from calibench.estimators.stage import iso230_2
from calibench.estimators.stage.compensation import (
    MODEL_DEGREES,
    LineRuler,
    compensated_command,
    fit_polynomial,
    select_model,
)
from calibench.scenarios.report import Check, Parameter, Report, progress
from calibench.scenes.vision_stage import VisionStageGeometry
from calibench.sim.vision_stage import LineRuler as RulerArtefact
from calibench.sim.vision_stage import VisionStageSim, VisionStageTruth

NAME = "vision-stage"
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

    def __post_init__(self):
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
RULER_SHORTER_BY_MM = (
    10.0  # measure_rulers lays each ruler over the travel less this (its ends clear)
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
            f"the microscope sees {field[0]:.3g} x {field[1]:.3g} mm; its field must hold one whole "
            f"{plate.diameter_mm:g} mm circle and not two ({plate.pitch_mm:g} mm pitch): working_distance_mm "
            f"from {lo:.4g} to {hi:.4g} with this camera",
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
                f"from {need} to {most} circles along {'XY'[axis]} ({need}: the model selection fits "
                f"polynomials up to degree {need - 1}, which need {need} along each axis; {most}: the plate's "
                f"{plate.n} x {plate.n} circles at {plate.pitch_mm:g} mm within the {g.travel_mm[axis]:g} mm "
                f"travel)",
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
                f"one line or more, each over the range the grid calibrates: {'XY'[axis]} from {lo:g} to "
                f"{hi:g} mm (a model is not tested where it extrapolates)",
            )
    # the line rulers: graduations far enough apart to read in order, two or more on each axis
    longest = min(g.travel_mm) - RULER_SHORTER_BY_MM
    if not MIN_RULER_PITCH_MM <= c.ruler_pitch_mm <= longest:
        raise bad(
            f"{NAME}.ruler_pitch_mm",
            c.ruler_pitch_mm,
            f"from {MIN_RULER_PITCH_MM:g} mm (graduations read in order through the aim's scatter) to "
            f"{longest:g} mm (two graduations on the {longest:g} mm ruler of the shorter axis)",
        )
    for key in ("ruler_aim_um", "ruler_error_um"):
        if getattr(c, key) / 1000 > MAX_RULER_SCATTER * c.ruler_pitch_mm:
            raise bad(
                f"{NAME}.{key}",
                getattr(c, key),
                f"a graduation's scatter is a small part of the pitch: at most {MAX_RULER_SCATTER:.0%} of "
                f"ruler_pitch_mm = {c.ruler_pitch_mm:g}, {MAX_RULER_SCATTER * c.ruler_pitch_mm * 1000:g} um",
            )
    if not 0 <= c.turn_error <= MAX_TURN_ERROR:
        raise bad(
            f"{NAME}.turn_error",
            c.turn_error,
            f"the fraction the operator's turn is off by: from 0 to {MAX_TURN_ERROR:g} (at 1 or more the "
            f"rotate-and-check loop does not converge)",
        )
    s = c.truth.squareness_rad
    if not abs(s) <= MAX_SQUARENESS_RAD:
        raise bad(
            f"{NAME}.truth.squareness_rad",
            s,
            f"a squareness error is a small angle: from -{MAX_SQUARENESS_RAD:g} to {MAX_SQUARENESS_RAD:g} rad "
            f"({MAX_SQUARENESS_RAD * 1000:g} mm per metre)",
        )


class Microscope:
    """Finds the circle nearest the image centre; keeps the true centres for the report."""

    def __init__(self, sim: VisionStageSim, config: VisionStageConfig, fidelity: str):
        self.sim, self.config, self.fidelity = sim, config, fidelity
        cam = config.geometry.camera
        self.centre = np.array([cam.cx, cam.cy])
        self.mm_per_px = config.geometry.working_distance_mm / cam.fx
        self.errors_px = []  # detected - true, every measurement
        self.last_image = None
        self.last_found = None
        self.last_true = None

    def offset_mm(self) -> np.ndarray:
        """Where the nearest circle's centre is from the image centre, in machine X, Y (mm)."""
        true = self._nearest_true()
        if self.fidelity == "render":
            img = self.sim.render(self.config.pixel_noise_dn, self.config.psf_px)
            fit = find_dark_circle(img)
            if fit is None:
                raise ValueError(
                    f"no whole circle in the microscope's view at reading {self.sim.reading_mm}"
                )
            found = fit.centre
            self.last_image = img
        else:
            found = true + self.sim.rng.normal(0, self.config.centre_noise_px, 2)
        self.errors_px.append(found - true)
        self.last_found, self.last_true = found, true
        d = found - self.centre
        # image x runs along machine X; image v runs against machine Y
        return np.array([d[0], -d[1]]) * self.mm_per_px

    def _nearest_true(self) -> np.ndarray:
        p = self.sim.point_in_body_mm("plate")
        plate = self.config.geometry.plate
        i, j = np.clip(np.rint(p / plate.pitch_mm), 0, plate.n - 1).astype(int)
        return self.sim.true_circle_px(j * plate.n + i)


def approach(sim: VisionStageSim, reading: np.ndarray) -> None:
    """Move to a reading from below on both axes (unidirectional approach)."""
    sim.move_path(np.array([reading - 0.02, reading], float))


def servo(
    sim: VisionStageSim, scope: Microscope, reading: np.ndarray, tol_px: float
) -> tuple[np.ndarray, int]:
    """Move until the nearest circle is within ``tol_px`` of the image centre.

    Returns the reading at which the circle's centre is on the optical axis (the final reading
    plus the residual offset measured in the last image) and the number of moves.
    """
    s = np.array(reading, float)
    for n in range(1, 8):
        approach(sim, s)
        off = scope.offset_mm()
        if np.all(np.abs(off) < tol_px * scope.mm_per_px):
            return s + off, n
        s = s + off
    raise ValueError(f"servo did not settle near reading {reading}")


def align_plate(sim, scope, config, rng):
    """The rotate-and-check loop. Returns (phi estimates in order, truths in order, s00)."""
    g = config.geometry
    pitch = g.plate.pitch_mm
    far = (config.grid[0] - 1) * pitch
    estimates, truths, turns = [], [], 0
    while True:
        s00, _ = servo(sim, scope, np.array(g.plate_origin_reading_mm), config.servo_tolerance_px)
        # a near circle first, so the far one can be found even when phi is large
        s_near, _ = servo(sim, scope, s00 + [4 * pitch, 0], config.servo_tolerance_px)
        coarse = np.arctan2(*(s_near - s00)[::-1])
        s_far, _ = servo(
            sim,
            scope,
            s00 + far * np.array([np.cos(coarse), np.sin(coarse)]),
            config.servo_tolerance_px,
        )
        d = s_far - s00
        estimates.append(float(np.arctan2(d[1], d[0])))
        truths.append(true_phi(sim, s00, s00 + [far, 0.0]))
        if (
            abs(estimates[-1]) * 1e6 <= config.align_tolerance_urad
            or turns >= config.align_max_turns
        ):
            return estimates, truths, s00
        # the operator turns the plate about circle (0, 0), imperfectly
        turn = -estimates[-1] * (1 + config.turn_error * rng.standard_normal())
        turn += config.turn_noise_urad * 1e-6 * rng.standard_normal()
        sim.set_plate_yaw(sim.plate_phi_rad + turn)
        turns += 1


def true_phi(sim: VisionStageSim, s_a: np.ndarray, s_b: np.ndarray) -> float:
    """The plate's angle to the X motion from reading s_a to s_b (a pure X move), from the
    geometric truth: that motion, seen in plate coordinates, turns by -phi."""
    d = sim.true_point_mm(*s_b, body="plate") - sim.true_point_mm(*s_a, body="plate")
    return float(-np.arctan2(d[1], d[0]))


def run(config: VisionStageConfig, seed: int, fidelity: str, out_dir: Path, rrd: bool) -> Report:
    """Simulate the vision measuring machine's table under its microscope, with a circle plate and an
    interferometer; calibrate it from what its sensors recorded; compare with the truth.

    The arguments and the Report: :class:`calibench.scenarios.registry.Scenario`.
    """
    rng = np.random.default_rng(seed)
    g = config.geometry
    sim = VisionStageSim(
        g, config.truth, np.random.default_rng(rng.integers(2**63)), render=fidelity == "render"
    )
    scope = Microscope(sim, config, fidelity)
    try:
        # 1. alignment ---------------------------------------------------------------------------
        phi_est, phi_true, s00 = align_plate(sim, scope, config, rng)
        phi_final = phi_est[-1]
        phi_residual = phi_true[-1]

        # 2. point pairs -------------------------------------------------------------------------
        nx, ny = config.grid
        pitch = g.plate.pitch_mm
        j, i = np.mgrid[0:ny, 0:nx]
        nominal = np.stack([i.ravel(), j.ravel()], axis=1) * pitch
        c, s = np.cos(phi_final), np.sin(phi_final)
        nominal_machine = nominal @ np.array([[c, s], [-s, c]])  # turned by phi
        readings = np.empty_like(nominal_machine)
        images = []
        for k, p in progress(enumerate(nominal_machine), "circles", len(nominal_machine)):
            readings[k], _ = servo(sim, scope, s00 + p, config.servo_tolerance_px)
            if scope.last_image is not None and k % nx in (0, nx - 1) and k // nx in (0, ny - 1):
                images.append((k, scope.last_image, scope.last_found, scope.last_true))
        rel = readings - readings[0]  # readings relative to circle (0, 0)
        err_um = (nominal_machine - rel) * 1000  # true - reading
        u, v = rel[:, 0], rel[:, 1]

        # 3. models ------------------------------------------------------------------------------
        cubic = [fit_polynomial(u, v, err_um[:, a], 3) for a in range(2)]
        selected = [select_model(u, v, err_um[:, a], along=a) for a in range(2)]
        best = [m for m, _ in selected]
        rulers = measure_rulers(sim, config, rng, s00)

        # truth for the coefficients: the same cubic fitted to the true error field at the
        # same readings, in the frame the alignment defines (X along the X motion)
        true_err = true_error_field(sim, readings, phi_residual)
        cubic_true = [fit_polynomial(u, v, true_err[:, a], 3) for a in range(2)]
        sigma_um = max(b.rmse for b in best)  # the points' own scatter, from the best model
        sigma_phi = np.sqrt(2) * sigma_um / 1000 / ((nx - 1) * pitch)

        # 4. verification ------------------------------------------------------------------------
        models = {
            "uncompensated": lambda r: np.zeros_like(r),
            "lineruler": lambda r: np.stack([rulers[0](r[:, 0]), rulers[1](r[:, 1])], axis=1),
            "polynomial": lambda r: np.stack(
                [cubic[a](*(r - readings[0]).T) for a in range(2)], axis=1
            ),
            "best": lambda r: np.stack([best[a](*(r - readings[0]).T) for a in range(2)], axis=1),
        }
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
            sigma_phi,
            cubic,
            cubic_true,
            u,
            v,
            sigma_um,
            verification,
            selected,
        )
        artifacts = dict(
            sim=sim,
            readings=readings,
            err_um=err_um,
            true_err=true_err,
            models=models,
            verification=verification,
            images=images,
            s00=s00,
            geometry=g,
        )
        if out_dir is not None:  # a Monte-Carlo trial keeps only the numbers
            _write_figure(out_dir, artifacts, config)
        if rrd and out_dir is not None:
            from calibench.scenarios.vision_stage import viewer

            viewer.log_run(out_dir / "run.rrd", report, artifacts)
            report.rrd = "run.rrd"
        return report
    finally:
        sim.close()


def true_error_field(sim: VisionStageSim, readings: np.ndarray, phi_residual: float) -> np.ndarray:
    """True - reading (um) at the readings, relative to the first, in the frame whose x runs
    along the X motion (the plate's frame turned back by its true residual angle)."""
    p = np.array([sim.true_point_mm(*r, body="plate") for r in readings])
    c, s = np.cos(phi_residual), np.sin(phi_residual)
    p = p @ np.array([[c, s], [-s, c]])
    return ((p - p[0]) - (readings - readings[0])) * 1000


def measure_rulers(sim: VisionStageSim, config: VisionStageConfig, rng, s00) -> list[LineRuler]:
    """Lay a ruler along X through the middle of the grid and one along Y, read them (Eq. 3)."""
    g = config.geometry
    out = []
    for axis in (0, 1):
        length = g.travel_mm[axis] - RULER_SHORTER_BY_MM
        n = int(length // config.ruler_pitch_mm) + 1
        other = 1 - axis
        mid = s00[other] + (config.grid[other] - 1) * g.plate.pitch_mm / 2
        origin = np.zeros(2)
        origin[axis], origin[other] = 4.0, mid
        angle = (0.0 if axis == 0 else np.pi / 2) + config.ruler_parallelism_urad * 1e-6
        ruler = RulerArtefact(
            origin_mm=origin,
            angle_rad=angle,
            pitch_mm=config.ruler_pitch_mm,
            graduation_errors_mm=rng.normal(0, config.ruler_error_um / 1000, n),
        )
        readings = [sim.ruler_reading(ruler, k, axis, mid, config.ruler_aim_um) for k in range(n)]
        out.append(LineRuler.from_graduations(np.array(readings), config.ruler_pitch_mm))
    return out


def interferometer_lines(config: VisionStageConfig, rng) -> list[tuple[int, float, np.ndarray]]:
    """(axis, other axis's coordinate, targets) of every line; targets irregularly spaced, as
    ISO 230-2 asks, so that periodic errors are not sampled in step, and inside the range the
    plate calibrated (a model is not tested where it extrapolates)."""
    g = config.geometry
    lines = []
    for axis, others in ((0, config.x_lines_at_y_mm), (1, config.y_lines_at_x_mm)):
        m = config.targets_per_line
        lo = g.plate_origin_reading_mm[axis] + 3.0
        hi = g.plate_origin_reading_mm[axis] + (config.grid[axis] - 1) * g.plate.pitch_mm - 3.0
        base = np.linspace(lo, hi, m)
        jitter = rng.uniform(-0.3, 0.3, m) * (base[1] - base[0])
        jitter[[0, -1]] = 0.0
        for o in others:
            lines.append((axis, o, base + jitter))
    return lines


def interferometer_test(sim, config, lines, model) -> list[dict]:
    """Bidirectional runs along each line: deviations (actual - target, um) and ISO 230-2."""
    out = []
    for axis, other, targets in lines:
        m, n = len(targets), config.runs
        # every position's compensated command, the same in every run: solved once, all at once
        along = np.r_[
            targets, targets[0] - 2.0, targets[-1] + 2.0
        ]  # the targets, then both overruns
        points = np.empty((m + 2, 2))
        points[:, axis], points[:, 1 - axis] = along, other
        commands = compensated_command(points, model)
        # each run: the overrun below, the targets up, the overrun above, the targets down
        up, down = np.r_[m, 0:m], np.r_[m + 1, m - 1 : -1 : -1]
        path = np.tile(np.r_[up, down], n)
        readings = sim.move_path(commands[path], path < m, axis, config.interferometer_noise_um)
        readings = readings.reshape(n, 2, m)  # run, direction (up, down), in the order of travel
        zero = readings[0, 0, 0] - targets[0]  # zeroed at the first target of the first run
        dev = {
            +1: ((readings[:, 0] - zero - targets) * 1000).T,
            -1: ((readings[:, 1, ::-1] - zero - targets) * 1000).T,
        }
        res = iso230_2.evaluate(targets, dev[+1], dev[-1])
        out.append(
            {
                "axis": "xy"[axis],
                "at_mm": other,
                "targets_mm": targets,
                "dev_up_um": dev[+1],
                "dev_down_um": dev[-1],
                "iso": res,
            }
        )
    return out


def build_report(
    config,
    seed,
    fidelity,
    scope,
    phi_est,
    phi_true,
    phi_residual,
    sigma_phi,
    cubic,
    cubic_true,
    u,
    v,
    sigma_um,
    verification,
    selected,
) -> Report:
    """The vision stage's Report: phi, the cubic's coefficients against the truth, the ISO 230-2 checks."""
    report = Report(scenario=NAME, seed=seed, fidelity=fidelity)
    report.parameters.append(
        Parameter(
            "phi_urad",
            "urad",
            phi_true[0] * 1e6,
            phi_est[0] * 1e6,
            sigma_phi * 1e6,
            tolerance=TOL_SIGMA * sigma_phi * 1e6,
        )
    )
    for a, axis in enumerate("xy"):
        std = cubic[a].coef_std(u, v, sigma_um)
        # the alignment's own error turns the reference frame: it enters the cross slopes
        slope = 2 if a == 0 else 1
        std[slope] = np.hypot(std[slope], sigma_phi * 1000)
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
        "point_scatter_um": sigma_um,
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


def _write_figure(out_dir: Path, a: dict, config) -> None:
    """vision_stage.png: the error field before and after compensation, and the interferometer."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out_dir.mkdir(parents=True, exist_ok=True)
    r, e = a["readings"], a["err_um"]
    fig, axes = plt.subplots(1, 3, figsize=(16, 4.8), constrained_layout=True)
    after = e - a["models"]["polynomial"](r)
    for ax, field, title, scale in (
        (axes[0], e, "error field before (um)", 0.5),
        (axes[1], after, "after the cubic (um, x10)", 5.0),
    ):
        q = ax.quiver(
            r[:, 0],
            r[:, 1],
            field[:, 0],
            field[:, 1],
            np.hypot(*field.T),
            angles="xy",
            scale_units="xy",
            scale=1 / scale,
            cmap="viridis",
        )
        fig.colorbar(q, ax=ax, label="|error| (um)")
        ax.set(title=title, xlabel="X reading (mm)", ylabel="Y reading (mm)", aspect="equal")
    ax = axes[2]
    colors = {"lineruler": "tab:orange", "polynomial": "tab:green", "best": "tab:blue"}
    for name, lines in a["verification"].items():
        if name not in colors:
            continue
        for k, ln in enumerate(lines):
            if ln["axis"] != "x":
                continue
            mean = (ln["iso"].mean_up + ln["iso"].mean_down) / 2
            ax.plot(
                ln["targets_mm"],
                mean,
                "-o",
                ms=3,
                color=colors[name],
                label=name if k == 0 else None,
            )
    worst = max(
        float(np.max(np.abs(ln["iso"].mean_bi))) for ln in a["verification"]["uncompensated"]
    )
    ax.set(
        title=f"interferometer, X lines (uncompensated {worst:.0f} um)",
        xlabel="X target (mm)",
        ylabel="mean bidirectional deviation (um)",
    )
    ax.legend()
    fig.savefig(out_dir / "vision_stage.png", dpi=90)
    plt.close(fig)


def prior(config: VisionStageConfig, rng: np.random.Generator) -> VisionStageConfig:
    """The plate laid at phi uniform in 0.5-2.5 mrad; the machine's errors as configured."""
    truth = dataclasses.replace(config.truth, plate_phi_rad=float(rng.uniform(0.5e-3, 2.5e-3)))
    return dataclasses.replace(config, truth=truth)
