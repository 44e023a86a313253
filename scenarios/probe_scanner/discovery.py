"""``calibench discover probe-scanner``: where a scanner's turns disagree with its twin.

The scene model: the tracer's rail (d, dL, alpha0) and the plate's centre calibrated on the
recording by least squares, as any user would
(``estimators.probe_scanner.calibration.calibrate_lsq``); the twin (MuJoCo's ray against the plate's
walls, and whatever effects the config's twin carries: ``discover --twin`` writes them, ``discover
--config`` replays them) then replays every encoder angle. What is left is searched: the table's
runout (harmonics per turn), the encoder's eccentricity, the probe's scale and offset; then a table
over the angle for what none of them explains.

Repeats: every turn samples the same encoder angles, so each angle is a station visited once
per turn; the held-out folds are whole turns.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from calibench.estimators.discovery.confounds import find_confounds
from calibench.estimators.discovery.effect import Drivers
from calibench.estimators.discovery.fit import (
    Signal,
    confounded,
    cv_residuals,
    fit_terms,
    lstsq,
    rms,
)
from calibench.estimators.discovery.noise import Noise, noise_floor, repeatability, resolution
from calibench.estimators.discovery.nonsmooth import NONSMOOTH_Z
from calibench.estimators.discovery.probe_scanner import (
    AXIS,
    AngleTable,
    ProbeOffset,
    Runout,
    ScannerDrivers,
    scanner_candidates,
)
from calibench.estimators.discovery.select import FLOOR, keep_table, prune, select
from calibench.scenarios.discover.fresh import structure
from calibench.scenarios.discover.gross import without_gross
from calibench.scenarios.probe_scanner import NAME
from calibench.scenarios.probe_scanner.discovery_sessions import SYMMETRY, TOP_HARMONIC, assemble
from calibench.scenarios.probe_scanner.discovery_words import (
    BIN_DEG,
    TURN_THE_PLATE,
    locate_scanner,
    look_alikes,
    runs_said,
    sessions_said,
)
from calibench.scenarios.report import BadInput

EXPERIMENTS = {
    "offset": "measure a gauge of known size (a ring): the probe's zero and the rail's dL are one "
    "column on one artefact",
    "scale": "measure two artefacts of different size",
    "encoder_eccentricity": "turn the artefact in its holder by 90 deg and measure again",
    "runout": "measure more turns",
}


def _twin(config, cal):
    """The config's twin (with whatever effects it carries) on the rail and plate ``cal``."""
    import dataclasses

    from calibench.sim.probe_scanner import ProbeScannerSim

    truth = dataclasses.replace(
        config.truth,
        d_mm=cal.d_mm,
        dL_mm=cal.dL_mm,
        alpha0_rad=cal.alpha0_rad,
        plate_centre_mm=tuple(float(c) for c in cal.centre_mm),
    )
    return ProbeScannerSim(config.geometry, truth)


# start angles of the rail's fit: the plate at rest, then turned by each 15 deg of its 90 deg
# symmetry; a fit within RAIL_FITS_MM (RMS) of the readings ends the search
PLATE_TURNS_RAD = tuple(np.deg2rad([0, 15, 30, 45, 60, 75, -15, -30, -45]))
RAIL_FITS_MM = 0.05


def scene_model(rec, config) -> tuple[object, np.ndarray, np.ndarray, np.ndarray]:
    """The calibrated rail and plate, the twin's reading at each encoder angle (n,) mm, the
    model's columns d rho / d(d, dL, alpha0, cx, cy) (n, 5) and d rho / d theta (n,)."""
    from calibench.estimators.probe_scanner.calibration import (
        ScannerCalibration,
        calibrate_lsq,
        rounded_square_rho,
    )

    g, nom = config.geometry, config.nominal
    a, rc = g.plate.half_side_mm, g.plate.corner_radius_mm
    th = rec.theta_rad
    cal, cal_rms = None, np.inf
    # the plate as clamped at rest first; a plate turned on the table (a second recording) from
    # start angles a quarter of its symmetry apart
    for turn in PLATE_TURNS_RAD:
        start = ScannerCalibration(nom.d_mm, nom.dL_mm, nom.alpha0_rad + turn, np.zeros(2))
        try:
            fit = calibrate_lsq(th, rec.rho_mm, a, rc, start)
        except np.linalg.LinAlgError:  # readings no rail can give: no inverse normal matrix
            continue
        rms_mm = np.nan if fit.rms_mm is None else fit.rms_mm
        if np.isfinite(rms_mm) and rms_mm < cal_rms:
            cal, cal_rms = fit, rms_mm
        if cal_rms < RAIL_FITS_MM:
            break
    if cal is None or not np.isfinite(cal_rms) or cal_rms > 1.0:
        fit_rms = "no fit" if cal is None else f"rms {cal_rms:.3g} mm"
        raise BadInput(
            f"the recording does not fit the calibration plate ({2 * a:g} mm square, r = {rc:g} "
            "mm) with "
            f"any rail ({fit_rms}): another artefact, a wrong unit (the format: mm and degrees), "
            "or not a probe-scanner recording?"
        )
    p = np.r_[cal.d_mm, cal.dL_mm, cal.alpha0_rad, cal.centre_mm]
    steps = np.array([1e-4, 1e-4, 1e-6, 1e-4, 1e-4])
    cols = np.empty((len(th), 5))
    for k in range(5):
        hi, lo = p.copy(), p.copy()
        hi[k] += steps[k]
        lo[k] -= steps[k]
        f = [rounded_square_rho(th, v[0], v[1], v[2], v[3:5], a, rc) for v in (hi, lo)]
        cols[:, k] = (f[0] - f[1]) / (2 * steps[k])
    if not np.all(np.isfinite(cols)):
        raise BadInput(
            f"the recording does not fit the calibration plate ({2 * a:g} mm square, r = {rc:g} "
            "mm): its rail's model has no slope there"
        )
    rho_twin = _twin(config, cal).reading_mm("plate", th)
    return cal, rho_twin, cols, cols[:, 2]


def find_angle_table(
    sig: Signal,
    terms: list,
    drivers: Drivers,
    noise: Noise,
    fold: np.ndarray,
    floor: float,
    count_mm: float = 0.0,
) -> AngleTable | None:
    """Bands of the angle whose mean residual (over turns) stands out of the repeatability and
    beyond half the reading's count ``count_mm`` (:func:`noise.resolution`: a coarse count
    repeats its error at each angle), grown to their neighbours (|z| > 2, within 3 bands,
    around the turn); kept only if a correction there helps held out."""
    if noise.sigma_mm is None:
        return None
    _, _, _, res = fit_terms(sig, terms, drivers, {}, None)
    n_bins = int(round(360 / BIN_DEG))
    band = np.floor(np.degrees(np.mod(drivers["theta"], 2 * np.pi)) / BIN_DEG).astype(int) % n_bins
    counts = np.bincount(band, minlength=n_bins)
    means = np.bincount(band, weights=res, minlength=n_bins) / np.maximum(counts, 1)
    z = means / (noise.sigma_mm * noise.inflation / np.sqrt(np.maximum(counts, 1)))
    z[counts < 2] = 0.0
    hot = (np.abs(z) > NONSMOOTH_Z) & (np.abs(means) > count_mm / 2)
    if hot.sum() < 2:
        return None
    near = np.zeros(n_bins, bool)
    for s in range(-3, 4):
        near |= np.roll(hot, s)
    region = hot | (near & (np.abs(z) > 2))
    table_id = -np.ones(n_bins, int)
    table_id[region] = np.arange(region.sum())
    peak = int(np.argmax(np.abs(z)))
    bands = np.flatnonzero(region)
    where = (
        f"at table angles {', '.join(runs_said(bands))} deg (largest at "
        f"{(peak + 0.5) * BIN_DEG:.1f} deg, {means[peak] * 1000:+.1f} um)"
    )
    table = AngleTable(
        table_id=table_id, bin_deg=BIN_DEG, where=where, peak_deg=(peak + 0.5) * BIN_DEG
    )
    # judged where it acts: a nick a degree wide barely moves the whole turn's RMS
    inside = table_id[band] >= 0
    cache: dict = {}
    before = rms(cv_residuals(sig, terms, drivers, fold, cache)[inside])
    after = rms(cv_residuals(sig, terms + [table], drivers, fold, cache)[inside])
    return table if after < (1 - floor) * before else None


def discover_scanner(rec, seed: int = 0, floor: float = FLOOR, config=None) -> tuple[dict, dict]:
    """discovery.json's content for a probe-scanner recording (or a list of recordings of one
    machine, fitted together: :mod:`.scanner_sessions`), and what the figure needs; samples with
    a gross reading (dust under the stylus, a missed count) set aside (:mod:`.gross`)."""
    from calibench.scenarios.probe_scanner.scenario import ProbeScannerConfig

    config = config or ProbeScannerConfig()
    recs = list(rec) if isinstance(rec, (list, tuple)) else [rec]
    return without_gross(lambda rs: _discover_scanner(rs, seed, floor, config), recs, "samples")


def _discover_scanner(recs: list, seed: int, floor: float, config) -> tuple[dict, dict]:
    from calibench.scenarios.discover.report import (
        Findings,
        describe_effects,
        discovery_json,
        judged,
    )

    for k, r in enumerate(recs):
        which = f"recording {k + 1}: " if len(recs) > 1 else ""
        if len(r) < 200:
            raise BadInput(
                f"{which}{len(r)} samples: discover probe-scanner needs at least 200 (a turn)"
            )
        if np.ptp(np.mod(r.theta_rad, 2 * np.pi)) < np.deg2rad(300):
            raise BadInput(
                f"{which}the samples cover less than 300 deg of the table: discover needs "
                "whole turns"
            )
    sessions = assemble(recs, config, scene_model)
    rec, cal = sessions.rec, sessions.cals[0]
    rho_twin, geo, slope = sessions.rho_twin, sessions.geo, sessions.slope
    n = len(rec)
    turns = np.unique(rec.turn)
    th = rec.theta_rad
    drivers: ScannerDrivers = {
        "theta": th,
        "rho": rho_twin,
        "drho": slope,
        "turn": rec.turn,
        "t_s": rec.t_s,
        "temp_c": rec.temp_c,
    }
    sig = Signal("rho_meas - rho_sim", AXIS, rec.rho_mm - rho_twin, geo, np.arange(n), th)
    if len(turns) >= 2:
        fold, scheme = np.searchsorted(turns, rec.turn), "leave one turn out"
    else:
        fold, scheme = np.arange(n) % 5, "five interleaved folds of the samples (one turn)"
    angle = np.round(np.degrees(np.mod(th, 2 * np.pi)), 6)
    station = np.unique(np.c_[sessions.rec_id, angle], axis=0, return_inverse=True)[1].ravel()
    order = rec.t_s if rec.t_s is not None else np.arange(n, dtype=float)
    first = sig.r - geo @ lstsq(geo, sig.r)
    # within a turn: a drift from turn to turn is not scatter (and must stay visible as a drift)
    noise = {AXIS: repeatability(first, station, order, rec.turn)}
    candidates = scanner_candidates(told_apart=sessions.form_harmonics)
    found, terms = select([sig], candidates, drivers, fold, noise, floor=floor)
    prune(sig, found, terms, drivers, fold, floor)
    count = resolution(rec.rho_mm)
    table = find_angle_table(sig, terms[AXIS], drivers, noise[AXIS], fold, floor, count)
    if table is not None:  # helps where it acts (find_angle_table): kept by the engine
        keep_table([sig], terms, found, drivers, fold, [table])
    effects, fitted = describe_effects([sig], terms, found, drivers, noise)
    after_noise = {AXIS: repeatability(fitted[AXIS], station, order, rec.turn)}
    confounds = []
    hidden = [
        h for h in range(SYMMETRY, TOP_HARMONIC + 1, SYMMETRY) if h not in sessions.form_harmonics
    ]
    if hidden:
        frac = confounded(sig, terms[AXIS], Runout(harmonic=hidden[0]), drivers, {})
        confounds.append(
            {
                "effect": "runout",
                "axis": AXIS,
                "with": "the square's form",
                "why": f"a runout {', '.join(map(str, hidden))} times a turn repeats with the "
                "square plate's sides: on these recordings it cannot be told from the plate's "
                f"form error ({100 * frac:.0f} % of a runout {hidden[0]} times a turn is what the "
                "calibrated rail already does), so those harmonics are not searched",
                "experiment": TURN_THE_PLATE,
            }
        )
    for f in find_confounds({AXIS: sig}, terms, [ProbeOffset()], drivers):
        confounds.append(
            {
                "effect": "offset",
                "axis": AXIS,
                "with": "the rail's dL",
                "why": f"{100 * f.fraction:.0f} % of a probe offset is what the rail's dL already "
                "does: on one artefact the two are one number",
                "experiment": EXPERIMENTS["offset"],
            }
        )
    confounds += look_alikes(sig, terms[AXIS], drivers)
    located = locate_scanner(sig, drivers, rec, seed)
    findings = Findings(
        scenario=NAME,
        samples=n,
        rms_nominal=float(np.sqrt(np.mean(first**2))),
        found=found,
        effects=effects,
        located=located,
        confounded=confounds,
        judgement=judged(
            found.cv_final,
            # a turn's successive angles are near-repeats of what is smooth in the angle
            {AXIS: noise_floor(fitted[AXIS], order, station, rec.turn, successive=True, path=th)},
            bool(effects),
            located,
            lambda: locate_scanner(dataclasses.replace(sig, r=fitted[AXIS]), drivers, rec, seed),
        ),
        holdout=scheme,
        scene_model=(
            f"the twin (MuJoCo's ray on the {2 * config.geometry.plate.half_side_mm:g} mm plate) "
            f"with its rail calibrated: d {cal.d_mm:.4f} mm, dL {cal.dL_mm:.4f} mm, alpha0 "
            f"{np.degrees(cal.alpha0_rad):.4f} deg, plate centre ({cal.centre_mm[0]:.4f}, "
            f"{cal.centre_mm[1]:.4f}) mm"
        ),
        noise=noise,
        after_noise=after_noise,
    )
    out = discovery_json(findings, {"twin_rail": _twin_rail(cal), **sessions_said(sessions)})
    return out, {
        "signals": [sig],
        "fitted": fitted,
        "abscissa": (np.degrees(np.mod(th, 2 * np.pi)), "table angle (deg)"),
        **structure(terms, drivers, fold),
    }


# The table's errors stay with its angle, the plate's form turns with the plate: a second
# recording with the plate turned separates a runout at the square's harmonics from that form.
# --- the plug-in (calibench.scenarios.discover.engine.Plugin) -------------------------------------
HOLDOUTS: tuple[str, ...] = ()  # its own folds: whole turns (or interleaved samples of one)
MANY_RECORDINGS = True  # the same machine with the plate turned: fitted together


def load(scenario: str, paths: list, arm=None):
    """The scanner recording(s) at ``paths`` (docs/formats.md: turn, theta_deg, rho_mm): one, or a
    list of several of the same machine."""
    from calibench.recordings import load_scanner_csv
    from calibench.scenarios.discover.engine import MAX_ROWS

    recs = [load_scanner_csv(p, MAX_ROWS) for p in paths]
    return recs[0] if len(recs) == 1 else recs


def discover(scenario: str, rec, seed: int, holdout, config, arm=None) -> tuple[dict, dict]:
    """:func:`discover_scanner` with the twin of the ``run --config`` file ``config``."""
    from calibench.scenarios.config import load_toml, override
    from calibench.scenarios.probe_scanner.scenario import ProbeScannerConfig

    cfg = ProbeScannerConfig()
    if config is not None:
        cfg = override(cfg, load_toml(config).get(NAME, {}), NAME)
    return discover_scanner(rec, seed, config=cfg)


def twin_tables(scenario: str, found: dict, config, arm=None) -> tuple[dict, list[str]]:
    """The twin's tables (:func:`.discovery_twin.twin_table`) and the accepted effects it cannot
    carry."""
    from calibench.scenarios.discover.twin_merge import carried, given_tables
    from calibench.scenarios.probe_scanner.discovery_twin import twin_table

    left = [
        e["name"]
        for e in found["effects"]
        if e["name"] not in ("runout", "encoder_eccentricity", "scale")
    ]
    # the replayed config's twin as given (its geometry, the rest of its truth) under the update
    given = given_tables(config, NAME)
    table = twin_table(found, given.get("truth"))[NAME]
    return {NAME: carried(given, table)}, left


def concealed(scenario: str, kind: str, seed: int, arm=None, **options) -> tuple[object, dict]:
    """The suites' proof set: a recording of the nominal twin with ``kind`` concealed
    (``sim.concealed.scanner_recording``), and its sealed manifest; ``options``: the
    generator's (``noise``, ``repeat``)."""
    from calibench.sim.concealed import scanner_recording

    return scanner_recording(kind, seed, **options)


def search(
    scenario: str, rec, seed: int, floor: float | None = None, arm=None
) -> tuple[dict, dict]:
    """discover's search on ``rec`` with the nominal twin (``floor``: None, the house's)."""
    return discover_scanner(rec, seed, FLOOR if floor is None else floor)


def recording_kinds(scenario: str) -> tuple[str, ...]:
    """The effects a run's recording may conceal: the proof set's, then the second suite's and
    the third's."""
    from calibench.sim.concealed.heat import SIMULATED_SCANNER_KINDS
    from calibench.sim.concealed.scanner import SCANNER_KINDS
    from calibench.sim.concealed.unwritten import UNWRITTEN_SCANNER_KINDS

    return SCANNER_KINDS + UNWRITTEN_SCANNER_KINDS + SIMULATED_SCANNER_KINDS


def run_recording(scenario: str, config, seed: int) -> tuple[object, dict]:
    """``run``'s recording: the proof set's turns on the config's twin, ``config.recording``'s
    effect concealed."""
    from calibench.sim.concealed.scanner import scanner_recording

    plan = config.recording
    return scanner_recording(
        plan.conceal, seed, turns=plan.turns, twin=config.truth, geometry=config.geometry
    )


def _twin_rail(cal) -> dict:
    """discovery.json's ``twin_rail``: the rail the twin was calibrated to (mm, rad)."""
    return {
        "d_mm": cal.d_mm,
        "dL_mm": cal.dL_mm,
        "alpha0_rad": cal.alpha0_rad,
        "plate_centre_mm": [float(c) for c in cal.centre_mm],
    }


def nonsmooth_at(scenario: str, truth: dict, found: dict) -> bool:
    """Whether a found ``nonsmooth`` table sits where a concealed local effect lives (the second
    suite's scoring): on its arc, with 2 deg of slack."""
    at = float(str(found["params"].get("where", "")).split("largest at ")[1].split(" deg")[0])
    off = (at - truth["params"]["theta_deg"] + 180) % 360 - 180
    return abs(off) <= truth["params"]["width_deg"] / 2 + 2.0
