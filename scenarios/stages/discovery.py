"""The stages' discovery plug-in (belt-stage, vision-stage).

The twin replays the commands (``sim.replay``); the scene's own error model (the belt stage's
quadratic map, the vision stage's cubic one) is calibrated with the data, as any user would; what
is left is searched: the drives' lost motion (constant, or growing along the travel), periodic
errors, thermal expansion and drift, smooth straightness and cross-coupling terms, then a
``nonsmooth`` table where stations stand out of the repeatability. Folds: whole passes, rows or
columns of a grid, or blocks (``--holdout``). The twin: each axis's ``DriveErrors``
(``sim.stage_drive``) with the accepted effects written in.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np

from calibench.estimators.discovery.effect import Effect
from calibench.estimators.discovery.fit import Signal, cv_residuals, fit_terms, lstsq
from calibench.estimators.discovery.lag import LagSearch
from calibench.estimators.discovery.noise import Floor, noise_floor, repeatability
from calibench.estimators.discovery.nonsmooth import find_nonsmooth
from calibench.estimators.discovery.rivals import ties
from calibench.estimators.discovery.select import FLOOR, Discovery, keep_table, refine, select
from calibench.estimators.discovery.stage import (
    PeriodSearch,
    StageDrivers,
    polynomial_candidates,
    stage_candidates,
)
from calibench.estimators.discovery.transient import TransientSearch
from calibench.recordings.stage import repeated_pass
from calibench.scenarios.discover.folds import block_folds
from calibench.scenarios.discover.fresh import structure
from calibench.scenarios.discover.report import (
    Findings,
    describe_effects,
    discovery_json,
    judged,
    named_only,
)
from calibench.scenarios.discover.twin_merge import carried, given_tables, stage_drives
from calibench.scenarios.report import BadInput
from calibench.scenarios.stages.discovery_words import locate_stage, stage_confounds

# the degree of the scene's own error map, by the registry's fit model of the stage
MAP_DEGREE = {"quadratic": 2, "cubic": 3}


def stage_degree(scenario: str) -> int:
    """The degree in (x, y) of ``scenario``'s own error map (its registry line's fit model)."""
    from calibench.scenarios.registry import instrument

    return MAP_DEGREE[str(instrument(scenario).fit_model)]


def poly_base(x: np.ndarray, y: np.ndarray, degree: int, span: tuple[float, float]) -> np.ndarray:
    """The scene's error model as columns: monomials x^i y^j, i + j <= degree (scaled)."""
    u, v = x / max(span[0], 1e-9), y / max(span[1], 1e-9)
    return np.stack([u**i * v ** (k - i) for k in range(degree + 1) for i in range(k + 1)], axis=1)


def _pass_offsets(run, n: int) -> np.ndarray:
    """(n, passes - 1) indicator columns of every pass but the first; (n, 0) with one pass."""
    if run is None:
        return np.zeros((n, 0))
    ids = np.unique(run, return_inverse=True)[1].ravel()
    return (ids[:, None] == np.arange(1, ids.max() + 1)[None, :]).astype(float)


def folds_for(rec_run, x, y, holdout: str | None) -> tuple[np.ndarray, str]:
    """Fold label per sample: whole passes when there are several, else whole rows (or columns)
    of a grid, else five contiguous blocks in time. A scheme asked for by name that the
    recording cannot give (one pass, no grid) is bad input, not quietly another scheme."""
    passes = rec_run is not None and len(np.unique(rec_run)) >= 2
    rows, cols = len(np.unique(y)) <= len(y) / 4, len(np.unique(x)) <= len(x) / 4
    if holdout == "pass" and not passes:
        raise BadInput(
            "--holdout pass: the recording has one pass (its run column); hold out rows, columns "
            "or blocks"
        )
    if holdout == "rows" and not rows:
        raise BadInput(
            f"--holdout rows: the recording's y values are not rows of a grid ({len(np.unique(y))} "
            f"distinct in {len(y)} samples); hold out blocks"
        )
    if holdout == "columns" and not cols:
        raise BadInput(
            f"--holdout columns: the recording's x values are not columns of a grid "
            f"({len(np.unique(x))} distinct in {len(x)} samples); hold out blocks"
        )
    if holdout in (None, "pass") and passes:
        return np.unique(rec_run, return_inverse=True)[1], "leave one pass out"
    if holdout in (None, "rows") and rows:
        return np.unique(y, return_inverse=True)[1], "leave one row (y) out"
    if holdout == "columns":
        return np.unique(x, return_inverse=True)[1], "leave one column (x) out"
    fold, scheme = block_folds(np.c_[x, y], "samples")
    return fold, scheme.replace("five contiguous blocks of samples", "five contiguous blocks")


# --- stages --------------------------------------------------------------------------------------
@dataclasses.dataclass
class StageScene:
    """A stage recording against its twin: the residual signals (each axis's reading minus the
    twin's replay, with the scene's error map as free columns), the candidates' drivers, and the
    keys that group repeated readings (``station``: the same place and approach, (n,);
    ``order``: the readings' order in time, (n,))."""

    signals: list[Signal]
    drivers: StageDrivers
    station: np.ndarray
    order: np.ndarray


def discover_stage(
    scenario: str,
    rec,
    seed: int = 0,
    holdout: str | None = None,
    floor: float = FLOOR,
    truth=None,
    geometry=None,
) -> tuple[dict, dict]:
    """discovery.json's content for a stage recording, and what the figure needs. ``truth`` and
    ``geometry``: the twin's as-built parameters and nominal geometry (a ``--config`` file's;
    default: the scenario's own)."""
    _check_recording(scenario, rec, geometry)
    deg = stage_degree(scenario)
    scene = stage_scene(scenario, rec, deg, truth, geometry)
    signals, drivers = scene.signals, scene.drivers
    x, y = rec.x_cmd_mm, rec.y_cmd_mm
    fold, scheme = folds_for(rec.run, x, y, holdout)
    base = signals[0].base
    noise = {
        s.axis: repeatability(s.r - base @ lstsq(base, s.r), scene.station, scene.order)
        for s in signals
    }
    candidates = _stage_candidates(drivers, deg)
    found, terms = select(signals, candidates, drivers, fold, noise, floor=floor)
    growing = _grow_backlash(signals, terms, found, drivers, fold, noise, floor)
    _add_station_tables(signals, terms, found, drivers, fold, noise, floor)
    effects, fitted, after = _described(scene, rec.run, terms, found, growing)
    # a mechanism is named only when it beats its look-alikes held out
    tied = named_only(effects, found, ties(signals, terms, candidates, drivers, fold))
    located = locate_stage(signals, drivers, seed)
    findings = Findings(
        scenario=scenario,
        samples=len(rec),
        rms_nominal=found.rms_nominal,
        found=found,
        effects=effects,
        located=located,
        confounded=stage_confounds(signals, terms, found, candidates, drivers, rec) + tied,
        judgement=judged(
            found.cv_final,
            stage_floors(scene, fitted, rec.run),
            bool(effects),
            located,
            lambda: locate_stage(
                [dataclasses.replace(s, r=fitted[s.axis]) for s in signals], drivers, seed
            ),
        ),
        holdout=scheme,
        scene_model=f"the twin plus its degree-{deg} error map in (x, y), calibrated",
        noise=noise,
        after_noise=after,
    )
    temp = None if rec.temp_c is None else float(np.mean(rec.temp_c))
    out = discovery_json(findings, {"temp_mean_c": temp})
    return out, {
        "signals": signals,
        "fitted": fitted,
        "x": x,
        "y": y,
        **structure(terms, drivers, fold),
    }


def _check_recording(scenario: str, rec, geometry) -> None:
    """BadInput for a recording discover cannot judge: too few stations, a pass repeated row
    for row, stations beyond the twin's travel."""
    n = len(rec)
    if n < 20:
        raise BadInput(f"{n} stations: discover needs at least 20")
    repeat = repeated_pass(rec)
    if repeat is not None:
        raise BadInput(
            f"the recording's {repeat} row for row, every value the same: a file appended to "
            "itself, or a read-out coarser than the stage's repeatability? Held out, a repeat "
            "would score a model on its own rows, and it carries no scatter to judge one by"
        )
    _within_travel(scenario, rec.x_cmd_mm, rec.y_cmd_mm, geometry)


def stage_scene(scenario: str, rec, deg: int, truth=None, geometry=None) -> StageScene:
    """The recording replayed by the twin: each axis's residual with the scene's degree-``deg``
    error map as free columns (BadInput where the stations do not span it), the drivers, and the
    keys of repeated readings."""
    from calibench.sim.replay import replay_stage

    n = len(rec)
    x, y = rec.x_cmd_mm, rec.y_cmd_mm
    twin = geometry or _config(scenario, None).geometry  # the scenario's own, by default
    sim = replay_stage(twin, x, y, rec.temp_c, truth)
    drivers: StageDrivers = {
        "x": x,
        "y": y,
        "dir_x": rec.dir_x,
        "dir_y": rec.dir_y,
        "t_s": rec.t_s,
        "temp_c": rec.temp_c,
        "run": rec.run,
    }
    span = (max(np.ptp(x), 1.0), max(np.ptp(y), 1.0))
    base = poly_base(x, y, deg, span)
    if np.linalg.matrix_rank(base) < base.shape[1]:
        raise BadInput(
            f"the stations do not span the {scenario} error model (degree {deg} in x and y): "
            "measure a grid or lines along both axes"
        )
    idx = np.arange(n)
    signals = [
        Signal("x_meas - x_sim", "x", rec.x_meas_mm - sim[:, 0], base, idx, x),
        Signal("y_meas - y_sim", "y", rec.y_meas_mm - sim[:, 1], base, idx, y),
    ]
    order = rec.t_s if rec.t_s is not None else idx.astype(float)
    dirs = [np.zeros(n) if d is None else d for d in (rec.dir_x, rec.dir_y)]
    station = np.unique(np.stack([x, y, *dirs], axis=1).round(6), axis=0, return_inverse=True)[
        1
    ].ravel()
    return StageScene(signals, drivers, station, order)


def stage_floors(scene: StageScene, fitted: dict, run) -> dict[str, Floor]:
    """Each axis's noise floor (:func:`~calibench.estimators.discovery.noise.noise_floor`) of its
    residual after the accepted effects: a station's repeats at their shortest lags, or a pass's
    successive readings (neighbouring stations of a line, near-repeats of what is smooth along
    it), whichever is smaller."""
    passes = np.zeros(len(scene.order), int) if run is None else np.asarray(run)
    return {
        s.axis: noise_floor(
            fitted[s.axis], scene.order, scene.station, passes, successive=True, path=s.u
        )
        for s in scene.signals
    }


def _stage_candidates(
    drivers: StageDrivers, deg: int
) -> list[Effect | PeriodSearch | LagSearch | TransientSearch]:
    """The stage's candidates, a periodic search over each axis's travel (uniform in frequency,
    five points per resolution element, 1 / travel) and the smooth terms above the map's
    degree."""
    x, y = drivers["x"], drivers["y"]
    step = np.median(np.diff(np.unique(np.r_[x, y]))) if len(np.unique(np.r_[x, y])) > 1 else 1.0
    candidates: list[Effect | PeriodSearch | LagSearch | TransientSearch]
    candidates = list(stage_candidates(drivers))
    for a, u in (("x", x), ("y", y)):
        # a temperature the axis sees through a lag, a transient after each reversal. No step in
        # time: held out by pass, one between passes is a pass's offset, and one within a pass is
        # tested by that pass alone (a drifting null took one for a claim)
        searched: list[LagSearch | TransientSearch] = [
            LagSearch(a),
            LagSearch(a, "thermal_drift"),
            TransientSearch(a),
        ]
        candidates += [c for c in searched if c.applies(drivers)]
        lo, hi = max(2.5 * step, 5.0), np.ptp(u) / 2
        if hi > lo:
            f = np.arange(1 / hi, 1 / lo, 1 / (5 * np.ptp(u)))
            candidates.append(PeriodSearch(a, 1 / f))
        candidates += polynomial_candidates(a, deg)
    return candidates


def _add_station_tables(
    signals: list[Signal],
    terms: dict,
    found: Discovery,
    drivers: StageDrivers,
    fold: np.ndarray,
    noise: dict,
    floor: float,
) -> None:
    """``nonsmooth``: on each axis, stations that stand out of the repeatability after the
    accepted effects, a correction table there where it helps held out on its own axis
    (:func:`find_nonsmooth`), kept by the engine's :func:`keep_table`."""
    x, y = drivers["x"], drivers["y"]
    pos_key, pos_inv = np.unique(np.stack([x, y], axis=1).round(6), axis=0, return_inverse=True)
    pos_inv = pos_inv.ravel()
    for s in signals:
        table = find_nonsmooth(
            s, terms[s.axis], drivers, pos_inv, pos_key, noise[s.axis], fold, floor
        )
        if table is not None:
            keep_table(signals, terms, found, drivers, fold, [table])


def _described(
    scene: StageScene, run, terms: dict, found: Discovery, growing: dict
) -> tuple[list[dict], dict, dict]:
    """The accepted effects in words with their parameters, each axis's residual after them
    (n,), and the repeatability left after them.

    The effects are described by a fit that also gives each pass its own offset (a pass's
    offset shared by all its readings would otherwise pass into any term that changes from pass
    to pass, a temperature's, with a standard error that ignores it), and their standard errors
    scale with the repeatability left after them and the passes' offsets (the first estimate
    holds what they explain). The verdict, the figure and the report's repeatability keep the
    passes' offsets: held out by pass, so is the residual they are compared with.
    """
    signals, drivers, key, order = scene.signals, scene.drivers, scene.station, scene.order
    fitted = {s.axis: fit_terms(s, terms[s.axis], drivers, {}, None)[3] for s in signals}
    after = {a: repeatability(fitted[a], key, order) for a in fitted}
    offsets = _pass_offsets(run, len(key))
    described = [dataclasses.replace(s, base=np.c_[s.base, offsets]) for s in signals]
    within = {
        s.axis: repeatability(fit_terms(s, terms[s.axis], drivers, {}, None)[3], key, order)
        for s in described
    }
    effects, _ = describe_effects(described, terms, found, drivers, within)
    for e in effects:
        if e["name"] == "backlash" and e["axis"] in growing:
            e["grows_along_travel"] = True
            e["cv_rms_constant_reversal"], e["cv_rms_growing_reversal"] = growing[e["axis"]]
            e["physics"] += (
                f" (held out on {e['axis']}: {growing[e['axis']][0] * 1000:.2f} um with a constant "
                f"reversal, {growing[e['axis']][1] * 1000:.2f} um with one that grows)"
            )
    return effects, fitted, after


def _grow_backlash(signals, terms, found, drivers, fold, noise, floor) -> dict:
    """Does an accepted lost motion grow along its axis's travel (an elastic drive)? Where it
    does, the term becomes the growing one in place. Returns axis -> (held-out RMS of that axis
    with a constant reversal, with the growing one)."""
    from calibench.estimators.discovery.stage import Backlash

    out = {}
    for s in signals:
        for i, t in enumerate(terms[s.axis]):
            if not (isinstance(t, Backlash) and t.span_mm is None):
                continue
            u = np.asarray(drivers[s.axis], float)
            richer = Backlash(axis=s.axis, span_mm=(float(u.min()), float(u.max())))
            ok, before, after = refine(
                s, terms[s.axis], i, richer, drivers, fold, noise[s.axis], floor
            )
            if ok:
                terms[s.axis][i] = richer
                for st in found.steps:
                    if st.term is t:
                        st.term = richer
                out[s.axis] = (before, after)
    if out:
        cv_sq = sum(
            float(np.sum(cv_residuals(s, terms[s.axis], drivers, fold, {}) ** 2)) for s in signals
        )
        found.cv_final = float(np.sqrt(cv_sq / sum(len(s.r) for s in signals)))
    return out


def _within_travel(scenario: str, x: np.ndarray, y: np.ndarray, geometry=None) -> None:
    """BadInput when a commanded station lies beyond the twin's travel (by more than 5 % of it):
    the twin cannot replay it, and a recording there is in another unit or of another stage."""
    travel = (geometry or _config(scenario, None).geometry).travel_mm
    for axis, v, t in (("x", x, travel[0]), ("y", y, travel[1])):
        if v.min() < -0.05 * t or v.max() > 1.05 * t:
            raise BadInput(
                f"{axis}_cmd_mm reaches {v.min() if v.min() < -0.05 * t else v.max():.6g} mm; the "
                "twin's "
                f"{scenario} travels 0-{t:g} mm in {axis}: a wrong unit (um?) or another stage"
            )


def paper_belt_recording(data_dir: Path):
    """The seed paper's measured belt-stage tables (the project's data/seed_belt_stage) as a stage
    recording: one row per station, error = measured - commanded (no passes, no directions)."""
    from calibench.recordings import StageRecording

    ex = np.loadtxt(Path(data_dir) / "x_axis_error_mm.csv", delimiter=",", skiprows=1)
    ey = np.loadtxt(Path(data_dir) / "y_axis_error_mm.csv", delimiter=",", skiprows=1)
    if not np.array_equal(ex[:, :2], ey[:, :2]):
        raise BadInput("the X and Y tables list different stations")
    x, y = ex[:, 0], ex[:, 1]
    return StageRecording(x_cmd_mm=x, y_cmd_mm=y, x_meas_mm=x + ex[:, 2], y_meas_mm=y + ey[:, 2])


def _config(scenario: str, path: Path | None):
    """The scenario's run config, overridden by the file at ``path`` (None: the defaults)."""
    from calibench.scenarios.config import load_toml, override
    from calibench.scenarios.registry import scenario as registered

    cfg = registered(scenario).config()
    if path is not None:
        cfg = override(cfg, load_toml(path).get(scenario, {}), scenario)
    return cfg


def stage_twin(scenario: str, path: Path | None) -> dict:
    """The stage twin's as-built truth and nominal geometry for ``discover``
    (:func:`discover_stage`'s keywords): the config file's, or none (the defaults)."""
    if path is None:
        return {}
    cfg = _config(scenario, path)
    return {"truth": cfg.truth, "geometry": cfg.geometry}


# --- the plug-in (calibench.scenarios.discover.engine.Plugin) -------------------------------------
HOLDOUTS = ("pass", "rows", "columns", "blocks")  # --holdout's schemes (folds_for)
MANY_RECORDINGS = True  # the same machine, cold and warm: fitted together (stage_sessions)


def load(scenario: str, paths: list, arm=None):
    """The stage recording(s) at ``paths`` (docs/formats.md: commanded and measured x, y): one, or a
    list of several of the same machine."""
    from calibench.recordings import load_stage_csv
    from calibench.scenarios.discover.engine import MAX_ROWS

    recs = [load_stage_csv(p, MAX_ROWS) for p in paths]
    return recs[0] if len(recs) == 1 else recs


def discover(scenario: str, rec, seed: int, holdout, config, arm=None) -> tuple[dict, dict]:
    """:func:`discover_stage` with the twin of the ``run --config`` file ``config``; several
    recordings of one machine are joined (:func:`stage_sessions.joined`) and discovered as one
    with each one's passes its own."""
    from calibench.scenarios.stages.discovery_sessions import joined, same_machine

    recs = list(rec) if isinstance(rec, (list, tuple)) else [rec]
    same_machine(recs, stage_degree(scenario))
    out, fig = discover_stage(scenario, joined(recs), seed, holdout, **stage_twin(scenario, config))
    fig["rows_used"] = [np.arange(len(r)) for r in recs]
    return out, fig


def twin_tables(scenario: str, found: dict, config, arm=None) -> tuple[dict, list[str]]:
    """Each axis's drive errors with the accepted effects written in, on top of ``config``'s
    twin, and the accepted effects the drives cannot carry."""
    drives, left = stage_drives(found, _config(scenario, config).truth)
    return {scenario: carried(given_tables(config, scenario), {"truth": drives})}, left


def concealed(scenario: str, kind: str, seed: int, arm=None, **options) -> tuple[object, dict]:
    """The suites' proof set: a recording of the nominal twin with ``kind`` concealed
    (``sim.concealed.stage_recording``), and its sealed manifest; ``options``: the generator's
    (``noise``, ``repeat``)."""
    from calibench.sim.concealed import stage_recording

    return stage_recording(scenario, kind, seed, **options)


def search(
    scenario: str, rec, seed: int, floor: float | None = None, arm=None
) -> tuple[dict, dict]:
    """discover's search on ``rec`` with the nominal twin (``floor``: None, the house's)."""
    return discover_stage(scenario, rec, seed, floor=FLOOR if floor is None else floor)


def recording_kinds(scenario: str) -> tuple[str, ...]:
    """The effects a run's recording may conceal: the proof set's (an elastic belt on the belt
    stage only), then the second suite's and the third's."""
    from calibench.sim.concealed.heat import SIMULATED_STAGE_KINDS
    from calibench.sim.concealed.stage import STAGE_KINDS
    from calibench.sim.concealed.unwritten import UNWRITTEN_STAGE_KINDS

    own = tuple(k for k in STAGE_KINDS if k != "elastic" or scenario == "belt-stage")
    return own + UNWRITTEN_STAGE_KINDS + SIMULATED_STAGE_KINDS


def run_recording(scenario: str, config, seed: int) -> tuple[object, dict]:
    """``run``'s recording: the proof set's lines on the config's twin (its travel, truth and
    geometry), ``config.recording``'s effect concealed."""
    from calibench.scenarios.run_recording import recorded_travel_mm
    from calibench.sim.concealed.stage import StagePlan, stage_recording

    plan = config.recording
    travel = recorded_travel_mm(scenario, config.geometry.travel_mm)
    lines = StagePlan(travel, plan.step_mm, plan.passes)
    return stage_recording(
        scenario, plan.conceal, seed, plan=lines, truth=config.truth, geometry=config.geometry
    )


def nonsmooth_at(scenario: str, truth: dict, found: dict) -> bool:
    """Whether a found ``nonsmooth`` table sits where a concealed local effect lives (the second
    suite's scoring): its largest deviation within a tenth of the proof set's travel of it."""
    from calibench.sim.concealed import PLANS

    at = float(str(found["params"].get("where", "")).split("largest at x = ")[1].split(" mm")[0])
    return abs(at - truth["params"]["x_mm"]) <= 0.1 * PLANS[scenario].travel_mm[0]
