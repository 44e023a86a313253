"""The rail's discovery adapter (:class:`calibench.scenarios.discover.engine.Plugin`).

The nominal twin (no scale error, no friction: MuJoCo again, :mod:`.twin`) replays the
recording's commands, each approached from its side; the residual is the reading minus the
replay. The scene model is the rail's offset (what a user zeroes anyway). The candidates are the
stages' own (``calibench.estimators.discovery.stage``): lost motion on reversal (``backlash``)
and a scale error (``positioning``, the first power of the position). Folds: whole passes. The
engine's pieces do the rest: the noise from repeats, the selection, the words and the verdict.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from calibench.errors import BadInput
from calibench.estimators.discovery.fit import Signal, fit_terms, lstsq
from calibench.estimators.discovery.noise import noise_floor, repeatability
from calibench.estimators.discovery.select import FLOOR, select
from calibench.estimators.discovery.stage import Backlash, Polynomial, StageDrivers
from calibench.scenarios.discover.fresh import structure
from calibench.scenarios.discover.report import (
    Findings,
    describe_effects,
    discovery_json,
    judged,
)
from tests.instruments.rail.recording import RailRecording, load_rail_csv
from tests.instruments.rail.twin import RailTruth, friction_for, lost_motion_mm, plan, replay

HOLDOUTS: tuple[str, ...] = ()  # the passes, always
MANY_RECORDINGS = False
MIN_ROWS = 20
NOMINAL = RailTruth(scale_ppm=0.0, friction_n=0.0)
# the suites' proof set: the plan of the scenario's defaults, its interferometer's noise
SUITE_STATIONS_MM = np.linspace(0.0, 200.0, 11)
SUITE_PASSES = 3
SUITE_NOISE_UM = 0.3
APPROACH_MM = float(SUITE_STATIONS_MM[1] - SUITE_STATIONS_MM[0])
SUITE_FRICTION_N = (0.4, 1.0)  # the concealed backlash's friction: 3-10 um of lost motion
KINDS = ("null", "backlash")


def load(scenario: str, paths: list, arm=None) -> RailRecording:
    """The rail recording at ``paths[0]`` (:mod:`.recording`'s format)."""
    from calibench.scenarios.discover.engine import MAX_ROWS

    return load_rail_csv(paths[0], MAX_ROWS)


def approach_mm(rec: RailRecording) -> float:
    """How far beyond a command the replay starts an approach from the other side: the
    recording's station step (its smallest distinct spacing), 1 mm at least."""
    step = np.diff(np.unique(rec.x_cmd_mm))
    return float(max(step.min() if len(step) else 1.0, 1.0))


def _check(rec: RailRecording) -> None:
    """BadInput for a recording discover cannot judge: too few readings, one pass, one
    direction."""
    if len(rec) < MIN_ROWS:
        raise BadInput(f"{len(rec)} readings: discover rail needs at least {MIN_ROWS}")
    if len(np.unique(rec.run)) < 2:
        raise BadInput("the recording has one pass (its run column): discover holds out passes")
    if len(np.unique(rec.dir_x)) < 2:
        raise BadInput("every reading approached one way: lost motion cannot be told apart")


def discover_rail(
    rec: RailRecording, seed: int = 0, floor: float = FLOOR, truth: RailTruth = NOMINAL
) -> tuple[dict, dict]:
    """discovery.json's content for a rail recording replayed by the twin of ``truth``, and what
    the figure needs (``seed``: nothing here is drawn)."""
    _check(rec)
    n = len(rec)
    x, idx = rec.x_cmd_mm, np.arange(n)
    sim = replay(truth, x, rec.dir_x, approach_mm(rec))
    sig = Signal("x_meas - x_sim", "x", rec.x_meas_mm - sim, np.ones((n, 1)), idx, x)
    drivers: StageDrivers = {"x": x, "y": np.zeros(n), "dir_x": rec.dir_x, "run": rec.run}
    fold = np.unique(rec.run, return_inverse=True)[1].ravel()
    station = np.unique(np.c_[x, rec.dir_x].round(6), axis=0, return_inverse=True)[1].ravel()
    noise = {"x": repeatability(sig.r - sig.base @ lstsq(sig.base, sig.r), station, idx)}
    candidates = [Backlash(axis="x"), Polynomial(name="positioning", axis="x", powers=((1, 0),))]
    found, terms = select([sig], candidates, drivers, fold, noise, floor=floor)
    fitted = fit_terms(sig, terms["x"], drivers, {}, None)[3]
    after = {"x": repeatability(fitted, station, idx)}
    # described with each pass's own offset (held out by pass, the selection could not use one)
    passes = (fold[:, None] == np.arange(1, fold.max() + 1)[None, :]).astype(float)
    described = dataclasses.replace(sig, base=np.c_[sig.base, passes])
    within = {
        "x": repeatability(fit_terms(described, terms["x"], drivers, {}, None)[3], station, idx)
    }
    effects, _ = describe_effects([described], terms, found, drivers, within)
    for e in effects:  # the positioning term's coefficient is mm over the travel: as a scale
        if e["name"] == "positioning":
            span = float(np.ptp(x))
            e["params"]["scale_ppm"] = e["params"]["x1y0_mm"] / span * 1e6
            e["stderr"]["scale_ppm"] = e["stderr"]["x1y0_mm"] / span * 1e6
            e["physics"] += f": a scale error of {e['params']['scale_ppm']:+.1f} ppm"
    findings = Findings(
        scenario="rail",
        samples=n,
        rms_nominal=found.rms_nominal,
        found=found,
        effects=effects,
        located=[],
        confounded=[],
        judgement=judged(
            found.cv_final,
            {"x": noise_floor(fitted, idx, station, rec.run, successive=True, path=x)},
            bool(effects),
            [],
            list,  # the rail's residual is tested against no driver
        ),
        holdout="leave one pass out",
        scene_model="the nominal twin (no scale error, no friction) plus the rail's offset",
        noise=noise,
        after_noise=after,
    )
    out = discovery_json(findings)
    fig = {"signals": [sig], "fitted": {"x": fitted}, "x": x, "y": np.zeros(n)}
    return out, {**fig, **structure(terms, drivers, fold)}


def _config(scenario: str, path):
    """The rail's run config, overridden by the ``run --config`` file at ``path`` (None: the
    defaults)."""
    from calibench.scenarios.config import load_toml, override
    from calibench.scenarios.registry import scenario as registered

    cfg = registered(scenario).config()
    return cfg if path is None else override(cfg, load_toml(path).get(scenario, {}), scenario)


def discover(scenario: str, rec, seed: int, holdout, config, arm=None) -> tuple[dict, dict]:
    """:func:`discover_rail` with the twin of the ``run --config`` file ``config`` (None: the
    nominal twin)."""
    truth = NOMINAL if config is None else _config(scenario, config).truth
    return discover_rail(rec, seed, truth=truth)


def twin_tables(scenario: str, found: dict, config, arm=None) -> tuple[dict, list[str]]:
    """The rail's twin with the accepted effects written in, on top of ``config``'s: a backlash's
    reversal as the friction at which the twin shows it (with the config's belt), a positioning
    term as the scale; anything else listed as not carried."""
    base = NOMINAL if config is None else _config(scenario, config).truth
    truth = {"scale_ppm": base.scale_ppm, "friction_n": base.friction_n}
    left = []
    for e in found["effects"]:
        if e["name"] == "backlash":
            # found beside the config's twin: the reversal it misses adds to its own
            shown = e["params"]["reversal_mm"]
            at = float(np.mean(SUITE_STATIONS_MM))
            if base.friction_n > 0:
                shown += lost_motion_mm(base, at, APPROACH_MM)
            truth["friction_n"] = friction_for(shown, base, at, APPROACH_MM)
        elif e["name"] == "positioning":
            truth["scale_ppm"] = base.scale_ppm + e["params"]["scale_ppm"]
        else:
            left.append(f"{e['name']} ({e['axis']})")
    truth["stiffness_n_per_m"] = base.stiffness_n_per_m
    return {scenario: {"truth": truth}}, left


def concealed(
    scenario: str, kind: str, seed: int, arm=None, noise: str = "gaussian", repeat: int = 0
) -> tuple[RailRecording, dict]:
    """The suites' proof set: the twin (no scale error) with ``kind`` concealed (``null``:
    nothing; ``backlash``: the carriage's friction drawn from :data:`SUITE_FRICTION_N`), run
    over the scenario's plan and read with ``noise`` (``sim.concealed.noise``; ``repeat``: the
    same machine read again), and the sealed manifest (the reversal the twin itself shows)."""
    from calibench.sim.concealed.noise import repeat_noise

    if kind not in KINDS:
        raise ValueError(f"rail conceals {', '.join(KINDS)}, not {kind!r}")
    rng = np.random.default_rng(seed)
    friction = float(rng.uniform(*SUITE_FRICTION_N)) if kind == "backlash" else 0.0
    x, d, run = plan(SUITE_STATIONS_MM, SUITE_PASSES)
    x_true = replay(dataclasses.replace(NOMINAL, friction_n=friction), x, d, APPROACH_MM)
    noisy = repeat_noise(noise, rng, seed, repeat)
    rec = RailRecording(x, x_true + noisy((len(x),), SUITE_NOISE_UM / 1000.0), d, run)
    effects = []
    if kind == "backlash":  # the twin's own: forward minus backward readings of each place
        reversal = float(np.mean(x_true[d > 0]) - np.mean(x_true[d < 0]))
        effects.append({"name": "backlash", "axis": "x", "params": {"reversal_mm": reversal}})
    manifest = {"effects": effects, "noise_um": SUITE_NOISE_UM, "friction_n": friction}
    return rec, manifest


def search(
    scenario: str, rec, seed: int, floor: float | None = None, arm=None
) -> tuple[dict, dict]:
    """discover's search on ``rec`` with the nominal twin (``floor``: None, the house's)."""
    return discover_rail(rec, seed, floor=FLOOR if floor is None else floor)


def recording_kinds(scenario: str) -> tuple[str, ...]:
    """The effects the proof set conceals (:func:`concealed`)."""
    return KINDS


def run_recording(scenario: str, config, seed: int) -> tuple[RailRecording, dict]:
    """``run``'s recording: the scenario's plan on the config's twin, and what it held."""
    from tests.instruments.rail.scenario import record, twin_truth

    rec, x_true = record(config, seed)
    truth = twin_truth(rec.x_cmd_mm, x_true, rec.dir_x)
    effects = [
        {"name": "backlash", "axis": "x", "params": {"reversal_mm": -truth["lost_motion_um"] / 1e3}}
    ]
    return rec, {"effects": effects, "noise_um": config.noise_um}
