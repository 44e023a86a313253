"""``calibench discover stewart``: where a platform's leg readings disagree with its twin.

The scene model: the twin (nominal hinges) at the pose the tracker measured, the tracker's
frame registered to the base (always, as a user would: the platform's forward kinematics from
the readings, then Gauss-Newton on the six frame parameters). What is left, leg by leg, is
searched: the hinge geometry, each leg's thermal growth, lost motion on reversal, its screw's
pitch error, and the legs' compliance under the axial loads the twin's statics (MuJoCo) give.

Repeats: poses commanded alike (every leg's reading within 4 sqrt(2) of the readings' stated
noise) and approached the same way by every leg are one station; the tracker's measured pose
would split them by its own noise.
"""

from __future__ import annotations

import numpy as np

from calibench.estimators.discovery.fit import Signal, lstsq
from calibench.estimators.discovery.noise import noise_floor, repeatability
from calibench.estimators.discovery.select import prune, select
from calibench.estimators.discovery.stewart import AXIS, StewartDrivers, stewart_candidates
from calibench.scenarios.discover.folds import block_folds
from calibench.scenarios.discover.fresh import structure
from calibench.scenarios.discover.gross import without_gross
from calibench.scenarios.discover.same_machine import (
    SAME_PLATFORM_MM,
    own_geometry_rms,
    refuse_another,
)
from calibench.scenarios.report import BadInput
from calibench.scenarios.stewart import NAME
from calibench.scenarios.stewart.discovery_locate import locate
from calibench.scenarios.stewart.discovery_sessions import frame_per_recording, joined

# The platform's practical floor: 4 % of the held-out RMS. One leg's effect shows on a sixth of
# the rows; the null recordings of the suite (benchmarks/discover.py) stay below 1 %.
STEWART_FLOOR = 0.04
# A pose whose leg disagrees with the nominal platform by more than this is no calibration error:
# the hinges' errors are tenths of a millimetre, the legs' compliance and growth micrometres.
MAX_LEG_RESIDUAL_MM = 10.0
# 42 hinge parameters and the frame's 6 from 6 readings a pose, with room for the folds
MIN_DISTINCT_POSES = 20
EXPERIMENTS = {
    "leg_compliance": "add a known payload to the platform, or hold poses that load the legs "
    "differently",
    "thermal_expansion": "let the machine's temperature change by several K during the recording, "
    "or record it again warm (discover takes both)",
    "backlash": "approach each pose with every leg extending, then retracting",
    "periodic": "measure at a finer step of the legs' lengths",
    "thermal_drift": "return to one pose at the start, middle and end of the recording",
}


def _hinge_points(R, t, r):
    return np.einsum("nij,kj->nki", R, r) + t[:, None, :]


def register(rec, geometry) -> tuple[np.ndarray, np.ndarray]:
    """The tracker frame in the base frame (R (3, 3), t (3,) mm): first from the poses the
    nominal legs' readings give (forward kinematics) against the tracker's, then refined on the
    legs' residuals by the identification core (six unknowns, to round-off)."""
    from calibench.estimators.rotations import rigid_transform
    from calibench.estimators.stewart.kinematics import forward_kinematics_many
    from calibench.estimators.stewart.registration import register_frame

    g = geometry
    r0, B0, l0 = g.platform_hinges_mm, g.base_hinges_mm, g.initial_lengths_mm
    home = np.array([0.0, 0.0, g.home_height_mm])
    Rb, tb, ok = forward_kinematics_many(rec.readings_mm + l0, r0, B0, np.eye(3), home)
    if ok.mean() < 0.5:
        raise BadInput(
            "the legs' readings give no pose of the nominal platform for most rows: not this "
            "machine's recording, or not readings relative to the initial lengths"
        )
    Rf, tf = rigid_transform(
        _hinge_points(rec.R, rec.t_mm, r0)[ok].reshape(-1, 3),
        _hinge_points(Rb, tb, r0)[ok].reshape(-1, 3),
    )
    s = register_frame(_problem(rec, g, Rf, tf)).state
    return s.Rf, s.tf


def _check_registered(rec, g, Rf, tf) -> None:
    """BadInput when a pose's legs disagree with the registered nominal platform by more than any
    calibration error could (MAX_LEG_RESIDUAL_MM): a corrupt row, a wrong unit, another machine."""
    res = _frame_model(rec, g, Rf, tf)[0].reshape(-1, 6)
    worst = np.abs(res).max(axis=1)
    far = worst > MAX_LEG_RESIDUAL_MM
    if far.mean() > 0.5:
        raise BadInput(
            f"the legs' readings disagree with the tracker's poses on the nominal platform by "
            f"{np.median(worst):.3g} mm (median): a wrong unit (the format: mm and degrees), "
            "readings not relative to the initial lengths, or another platform (--config)"
        )
    if far.any():
        rows = np.flatnonzero(far)
        listed = ", ".join(str(int(k) + 1) for k in rows[:5]) + (" ..." if len(rows) > 5 else "")
        raise BadInput(
            f"data row(s) {listed}: the legs' readings disagree with the tracker's pose by up to "
            f"{worst[far].max():.3g} mm, where the other rows agree within "
            f"{worst[~far].max():.3g} mm: corrupt rows (leave them out)"
        )


def _problem(rec, g, Rf, tf):
    """The registration problem of ``rec``'s readings on the geometry ``g`` from the frame
    (Rf, tf) (:class:`~calibench.estimators.stewart.registration.RegistrationProblem`)."""
    from calibench.estimators.stewart.registration import RegistrationProblem, RegistrationState

    f = np.asarray
    start = RegistrationState(
        f(Rf, float),
        f(tf, float),
        f(g.platform_hinges_mm, float),
        f(g.base_hinges_mm, float),
        f(g.initial_lengths_mm, float),
    )
    return RegistrationProblem(rec.readings_mm, rec.R, rec.t_mm, start)


def _frame_model(rec, g, Rf, tf):
    """At the frame (Rf, tf): the residual readings (6 n,) (measured minus modelled), their
    columns d model / d (turn, shift) of the frame (6 n, 6) and d model / d (the legs' r, B, l)
    (n, 6, 42), the legs' lengths (n, 6), and the base-frame poses (R (n, 3, 3), t (n, 3))."""
    problem = _problem(rec, g, Rf, tf)
    s = problem.start()
    R, _, L, _ = problem.legs(s)
    J = problem.jacobian(s)
    t = rec.t_mm @ np.asarray(Rf).T + tf
    return -problem.residuals(s), J[:, :6], J[:, 6:].reshape(len(R), 6, 42), L, (R, t)


def twin_drivers(
    rec, geometry, Rf, tf, load=None, truth=None
) -> tuple[StewartDrivers, np.ndarray, np.ndarray]:
    """The candidates' drivers at the registered poses, the residual (6 n,) and the frame's
    columns (6 n, 6); the legs' axial forces from MuJoCo's statics of the twin (``geometry``,
    rigid legs). With ``truth`` (a twin updated by ``discover --twin``) its leg physics is part
    of the twin's readings: the residual is what is left beyond it."""
    from calibench.sim.stewart import StewartSim, StewartTruth, leg_effects_mm

    g = geometry
    res, frame, J, L, (R, t) = _frame_model(rec, g, Rf, tf)
    n = len(rec)
    twin = StewartSim(
        g,
        StewartTruth(hinge_error_mm=0.0, length_error_mm=0.0, station_offset_mm=0.0),
        np.random.default_rng(0),
    )
    loads = np.zeros(n) if load is None else load
    force = np.array([twin.leg_forces_n(R[k], t[k], loads[k]) for k in range(n)])
    if truth is not None and truth.has_leg_physics:
        res = res - leg_effects_mm(truth, L, force, rec.direction, rec.temp_c).ravel()
    drivers: StewartDrivers = {
        "L": L,
        "J_geo": J,
        "dir": rec.direction,
        "temp_c": rec.temp_c,
        "t_s": rec.t_s,
        "force": force,
        "frame": frame,
    }
    return drivers, res, frame


# two readings of one commanded leg length differ by the readings' noise times sqrt(2): 4 of
# those (a repeat is never split by noise, and the legs' micrometres tell commanded poses apart)
REPEAT_TOL_SIGMA = 4 * np.sqrt(2)


def stations(rec, tol_mm: float) -> np.ndarray:
    """Station id (n,) per pose: poses whose six leg readings (what was commanded) agree within
    ``tol_mm`` and, with directions, approached the same way by every leg. Not the tracker's
    measured pose: its noise (tens of micrometres at a few metres) would split true repeats and
    keep only the lucky ones, and the repeatability would come out too small."""
    from scipy.spatial import cKDTree

    key = np.asarray(rec.readings_mm, float) / tol_mm
    if rec.direction is not None:
        key = np.c_[key, 1e6 * rec.direction]
    tree = cKDTree(key)
    ids = np.arange(len(key))
    for i, j in sorted(tree.query_pairs(1.0, p=np.inf)):
        ids[j] = min(ids[j], ids[i])
    return np.unique(ids, return_inverse=True)[1].ravel()


def geometry_residual(rec, geometry, Rf, tf) -> np.ndarray:
    """The legs' residual readings (n_poses, 6) mm after the hinges, initial lengths and tracker
    frame are calibrated together on the identification core, to round-off: one linear step
    leaves about a micrometre of the hinges' 0.4 mm (second order in the frame's turn), which
    would look like structure."""
    from calibench.estimators.stewart.registration import register_with_legs

    problem = _problem(rec, geometry, Rf, tf)
    return -problem.residuals(register_with_legs(problem).state).reshape(-1, 6)


def discover_stewart(
    rec, seed: int = 0, floor: float = STEWART_FLOOR, config=None
) -> tuple[dict, dict]:
    """discovery.json's content for a Stewart recording (or several of one platform: a list,
    fitted together by :mod:`stewart_sessions`), and what the figure needs.

    Poses with a gross reading (a leg's residual beyond ``GROSS_SIGMAS`` robust standard
    deviations after the model: a tracker that lost a reflector's beam for a moment) are set
    aside and the discovery is run again without them; the report names them."""
    from calibench.scenarios.stewart.scenario import StewartConfig

    config = config or StewartConfig()
    recs = list(rec) if isinstance(rec, (list, tuple)) else [rec]
    for k, r in enumerate(recs):
        if len(recs) > 1 and len(r) < MIN_DISTINCT_POSES:
            raise BadInput(
                f"recording {k + 1} has {len(r)} poses: each needs at least {MIN_DISTINCT_POSES} "
                "for its tracker's frame"
            )

    def run(rs: list) -> tuple[dict, dict]:
        if len(rs) == 1:
            return _discover_stewart(rs[0], np.zeros(len(rs[0]), int), seed, floor, config)
        return _discover_stewart(*joined(rs, config.geometry, _registered), seed, floor, config)

    return without_gross(run, recs, "poses")


def stewart_confounds(sig, terms, candidates, drivers, temp_c) -> list[dict]:
    """The physical candidates the readings cannot tell from the hinges and the accepted effects
    (:func:`~calibench.estimators.discovery.confounds.find_confounds`), in words, each with the
    experiment that separates them; a thermal expansion on a temperature that barely moved is
    said once, for the six legs alike."""
    from calibench.estimators.discovery.confounds import find_confounds

    accepted = {t.key for t in terms[AXIS]}
    asked = [
        c
        for c in candidates
        if c.key not in accepted and hasattr(c, "columns") and c.name != "geometry"
    ]
    out: list[dict] = []
    for f in find_confounds({AXIS: sig}, terms, asked, drivers, temp_c):
        name = f.candidate.name
        if f.cause == "temperature":
            if not any(e["effect"] == name for e in out):
                out.append(
                    {
                        "effect": name,
                        "axis": AXIS,
                        "with": "the legs' length scales and the hinges",
                        "why": f"the temperature moved only {f.temperature_span_k:.2f} K, so a "
                        "leg's growth with it is a scale of its length, which the hinges take "
                        "in part",
                        "experiment": EXPERIMENTS[name],
                    }
                )
        else:
            out.append(
                {
                    "effect": name,
                    "axis": AXIS,
                    "with": "the hinge geometry and the accepted effects",
                    "why": f"{100 * f.fraction:.0f} % of {f.candidate.key}'s effect on the "
                    "readings is what the model already has",
                    "experiment": EXPERIMENTS.get(name, "vary its driver"),
                }
            )
    return out


def _selectable(candidates: list, temp_c: np.ndarray | None) -> list:
    """The candidates selection may accept: a leg's growth with a temperature that moved less
    than ``MIN_TEMPERATURE_SPAN_K`` is any slow drift in time, whatever the air did (a null's
    drifting reading took 1500 ppm/K), so it is only asked as a confound."""
    from calibench.estimators.discovery.confounds import MIN_TEMPERATURE_SPAN_K

    span = 0.0 if temp_c is None else float(np.ptp(np.asarray(temp_c, float)))
    return [
        c for c in candidates if c.name != "thermal_expansion" or span >= MIN_TEMPERATURE_SPAN_K
    ]


def _registered(rec, g) -> tuple[np.ndarray, np.ndarray]:
    Rf, tf = register(rec, g)
    _check_registered(rec, g, Rf, tf)
    return Rf, tf


def _discover_stewart(rec, rec_id, seed: int, floor: float, config) -> tuple[dict, dict]:
    from calibench.scenarios.discover.report import (
        Findings,
        describe_effects,
        discovery_json,
        judged,
    )
    from calibench.scenarios.stewart.scenario import StewartConfig
    from calibench.sim.stewart import leg_effects_mm

    config = config or StewartConfig()
    g = config.geometry
    n = len(rec)
    if n < 60:
        raise BadInput(
            f"{n} poses: discover stewart needs at least 60 (42 hinge parameters and the "
            "tracker's frame)"
        )
    repeat_tol = REPEAT_TOL_SIGMA * config.truth.reading_noise_um / 1000
    distinct = len(np.unique(stations(rec, repeat_tol)))
    if distinct < MIN_DISTINCT_POSES:
        raise BadInput(
            f"{distinct} distinct poses among {n}: the hinges need at least {MIN_DISTINCT_POSES} "
            "poses spread over the workspace"
        )
    Rf, tf = register(rec, g)
    _check_registered(rec, g, Rf, tf)
    truth = config.truth if config.truth.has_leg_physics else None
    drivers, r, frame = twin_drivers(rec, g, Rf, tf, rec.load_n, truth)
    if truth is not None:  # register again with the twin's leg physics taken out of the readings
        import dataclasses

        own = leg_effects_mm(truth, drivers["L"], drivers["force"], rec.direction, rec.temp_c)
        Rf, tf = register(dataclasses.replace(rec, readings_mm=rec.readings_mm - own), g)
        drivers, r, frame = twin_drivers(rec, g, Rf, tf, rec.load_n, truth)
    if rec_id.max() > 0:  # each recording's tracker frame: what its registration left
        frame = frame_per_recording(frame, rec_id)
    sig = Signal("reading - twin", AXIS, r, frame, np.repeat(np.arange(n), 6))
    fold, scheme = block_folds(rec.readings_mm, "poses")
    if rec_id.max() > 0:  # each recording's own blocks: every fold holds out part of each
        parts = [block_folds(rec.readings_mm[rec_id == k], "poses") for k in np.unique(rec_id)]
        fold = np.concatenate([f for f, _ in parts])
        scheme = parts[0][1] + " of each recording"
    legs = np.tile(np.arange(6), n)
    station = np.repeat(stations(rec, repeat_tol), 6) * 6 + legs
    order = (
        np.repeat(rec.t_s if rec.t_s is not None else np.arange(n, dtype=float), 6)
        + np.tile(np.arange(6), n) * 1e-3
    )
    candidates = stewart_candidates(drivers)
    geo = next(c for c in candidates if c.name == "geometry")
    first = r - np.c_[frame, geo.columns(drivers)] @ lstsq(np.c_[frame, geo.columns(drivers)], r)
    noise = {AXIS: repeatability(first, station, order)}
    found, terms = select(
        [sig], _selectable(candidates, rec.temp_c), drivers, fold, noise, floor=floor
    )
    prune(sig, found, terms, drivers, fold, floor)
    if rec_id.max() > 0:
        moved, left = own_geometry_rms(sig, terms[AXIS], geo, drivers, rec_id)
        refuse_another(moved, left, SAME_PLATFORM_MM, "platform", "hinges")
    effects, fitted = describe_effects([sig], terms, found, drivers, noise)
    after_noise = {AXIS: repeatability(fitted[AXIS], station, order)}
    # the platform keeps its written pairs (stewart_confounds), not the head to head of the arm
    # and the stages: a leg's growth with a temperature that rises as a first-order lag has the
    # very shape of a warm-up in time, and the two tie held out (the first suite's thermal leg)
    confounds = stewart_confounds(sig, terms, candidates, drivers, rec.temp_c)
    names = [e["name"] for e in effects if e["name"] != "geometry"]
    located = locate(geometry_residual(rec, g, Rf, tf), drivers, seed)
    findings = Findings(
        scenario=NAME,
        samples=n,
        rms_nominal=float(np.sqrt(np.mean(r**2))),
        found=found,
        effects=effects,
        located=located,
        confounded=confounds,
        judgement=judged(
            found.cv_final,
            # the poses come in random order: successive readings are not repeats
            {AXIS: noise_floor(fitted[AXIS], order, station, legs, path=drivers["L"].ravel())},
            bool(names),
            located,
            lambda: locate(fitted[AXIS].reshape(-1, 6), drivers, seed),
        ),
        holdout=scheme,
        scene_model="the nominal platform (drawing hinges, rigid legs) at the tracker's poses, "
        "the tracker's frame registered",
        noise=noise,
        after_noise=after_noise,
    )
    said = {
        "tracker_frame": {"R": Rf.tolist(), "t_mm": tf.tolist()},
        "temp_mean_c": None if rec.temp_c is None else float(np.mean(rec.temp_c)),
    }
    out = discovery_json(findings, said)
    if rec_id.max() > 0:
        out["recordings"] = int(rec_id.max()) + 1
    return out, {
        "signals": [sig],
        "fitted": fitted,
        "abscissa": (np.arange(len(r)) / 6, "pose (legs 1-6 each)"),
        **structure(terms, drivers, fold),
    }


# --- the plug-in (calibench.scenarios.discover.engine.Plugin) -------------------------------------
from calibench.scenarios.stewart.discovery_twin import twin_tables as twin_tables  # noqa: E402

HOLDOUTS: tuple[str, ...] = ()  # its own folds: blocks of poses (folds.block_folds)
MANY_RECORDINGS = True  # one platform, warm and cold, say: fitted together (stewart_sessions)


def load(scenario: str, paths: list, arm=None):
    """The platform's recordings at ``paths`` (docs/formats.md: l1_mm .. l6_mm and the tracker's
    pose): one, or a list of several."""
    from calibench.recordings import load_stewart_csv
    from calibench.scenarios.discover.engine import MAX_ROWS

    recs = [load_stewart_csv(p, MAX_ROWS) for p in paths]
    return recs[0] if len(recs) == 1 else recs


def discover(scenario: str, rec, seed: int, holdout, config, arm=None) -> tuple[dict, dict]:
    """:func:`discover_stewart` with the twin of the ``run --config`` file ``config``."""
    from calibench.scenarios.config import load_toml, override
    from calibench.scenarios.stewart.scenario import StewartConfig

    cfg = StewartConfig()
    if config is not None:
        cfg = override(cfg, load_toml(config).get(NAME, {}), NAME)
    return discover_stewart(rec, seed, config=cfg)


def concealed(scenario: str, kind: str, seed: int, arm=None, **options) -> tuple[object, dict]:
    """The suites' proof set: a recording of the nominal twin with ``kind`` concealed
    (``sim.concealed.stewart_recording``), and its sealed manifest; ``options``: the
    generator's (``noise``, ``repeat``)."""
    from calibench.sim.concealed import stewart_recording

    return stewart_recording(kind, seed, **options)


def search(
    scenario: str, rec, seed: int, floor: float | None = None, arm=None
) -> tuple[dict, dict]:
    """discover's search on ``rec`` with the nominal twin (``floor``: None, the platform's)."""
    return discover_stewart(rec, seed, STEWART_FLOOR if floor is None else floor)


def recording_kinds(scenario: str) -> tuple[str, ...]:
    """The effects a run's recording may conceal: the proof set's, then the second suite's and
    the third's."""
    from calibench.sim.concealed.heat import SIMULATED_STEWART_KINDS
    from calibench.sim.concealed.stewart import STEWART_KINDS
    from calibench.sim.concealed.unwritten import UNWRITTEN_STEWART_KINDS

    return STEWART_KINDS + UNWRITTEN_STEWART_KINDS + SIMULATED_STEWART_KINDS


def run_recording(scenario: str, config, seed: int) -> tuple[object, dict]:
    """``run``'s recording: the proof set's poses on the config's twin, ``config.recording``'s
    effect concealed."""
    from calibench.sim.concealed.stewart import stewart_recording

    plan = config.recording
    return stewart_recording(
        plan.conceal, seed, n_poses=plan.poses, twin=config.truth, geometry=config.geometry
    )
