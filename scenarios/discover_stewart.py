"""``calibench discover stewart``: where a platform's leg readings disagree with its twin.

The scene model: the twin (nominal hinges) at the pose the tracker measured, the tracker's
frame registered to the base (always, as a user would: the platform's forward kinematics from
the readings, then Gauss-Newton on the six frame parameters). What is left, leg by leg, is
searched: the hinge geometry, each leg's thermal growth, lost motion on reversal, its screw's
pitch error, and the legs' compliance under the axial loads the twin's statics (MuJoCo) give.

Repeats: poses the tracker found at the same place (within 20 um and 20 urad) approached the
same way by every leg are one station.
"""

from __future__ import annotations

import numpy as np

from calibench.estimators import discovery as dsc
from calibench.estimators.stewart_effects import AXIS, stewart_candidates
from calibench.scenarios.report import BadInput

# The platform's practical floor: 4 % of the held-out RMS. One leg's effect shows on a sixth of
# the rows; the null recordings of the suite (benchmarks/discover.py) stay below 1 %.
STEWART_FLOOR = 0.04
EXPERIMENTS = {
    "leg_compliance": "add a known payload to the platform, or hold poses that load the legs differently",
    "thermal_expansion": "let the machine's temperature change by several K during the recording",
    "backlash": "approach each pose with every leg extending, then retracting",
    "periodic": "measure at a finer step of the legs' lengths",
}


def _hinge_points(R, t, r):
    return np.einsum("nij,kj->nki", R, r) + t[:, None, :]


def register(rec, geometry, iterations: int = 10) -> tuple[np.ndarray, np.ndarray]:
    """The tracker frame in the base frame (R (3, 3), t (3,) mm): first from the poses the
    nominal legs' readings give (forward kinematics) against the tracker's, then Gauss-Newton on
    the legs' residuals."""
    from calibench.estimators.rotations import rigid_transform, rotvec_to_matrix
    from calibench.estimators.stewart import forward_kinematics_many

    g = geometry
    r0, B0, l0 = g.platform_hinges_mm, g.base_hinges_mm, g.initial_lengths_mm
    home = np.array([0.0, 0.0, g.home_height_mm])
    Rb, tb, ok = forward_kinematics_many(rec.readings_mm + l0, r0, B0, np.eye(3), home)
    if ok.mean() < 0.5:
        raise BadInput("the legs' readings give no pose of the nominal platform for most rows: not this machine's "
                       "recording, or not readings relative to the initial lengths")
    Rf, tf = rigid_transform(_hinge_points(rec.R, rec.t_mm, r0)[ok].reshape(-1, 3),
                             _hinge_points(Rb, tb, r0)[ok].reshape(-1, 3))
    for _ in range(iterations):
        res, cols, _ = _frame_model(rec, geometry, Rf, tf)
        step = np.linalg.lstsq(cols, res, rcond=None)[0]  # res falls by cols @ step
        Rf, tf = rotvec_to_matrix(step[:3]) @ Rf, rotvec_to_matrix(step[:3]) @ tf + step[3:]
        if np.max(np.abs(step)) < 1e-10:
            break
    return Rf, tf


def _frame_model(rec, g, Rf, tf):
    """Residual readings (6 n,) at the frame (Rf, tf), their columns d / d(turn, shift) of the
    frame (6 n, 6), and the base-frame poses (R (n, 3, 3), t (n, 3))."""
    R = np.einsum("ij,njk->nik", Rf, rec.R)
    t = rec.t_mm @ Rf.T + tf
    P = _hinge_points(R, t, g.platform_hinges_mm)
    v = P - g.base_hinges_mm
    L = np.linalg.norm(v, axis=2)
    u = v / L[..., None]
    res = (rec.readings_mm - (L - g.initial_lengths_mm)).ravel()
    # a turn w of the frame moves P by w x P: dL = u . (w x P) = w . (P x u)
    cols = np.concatenate([np.cross(P, u), u], axis=2).reshape(-1, 6)
    return res, cols, (R, t)


def twin_drivers(rec, geometry, Rf, tf, load=None, truth=None) -> tuple[dict, np.ndarray, np.ndarray]:
    """The candidates' drivers at the registered poses, the residual (6 n,) and the frame's
    columns (6 n, 6); the legs' axial forces from MuJoCo's statics of the twin (``geometry``,
    rigid legs). With ``truth`` (a twin updated by ``discover --twin``) its leg physics is part
    of the twin's readings: the residual is what is left beyond it."""
    from calibench.sim.stewart import StewartSim, StewartTruth, leg_effects_mm

    g = geometry
    res, frame, (R, t) = _frame_model(rec, g, Rf, tf)
    P = _hinge_points(R, t, g.platform_hinges_mm)
    v = P - g.base_hinges_mm
    L = np.linalg.norm(v, axis=2)
    u = v / L[..., None]
    n = len(rec)
    J = np.zeros((n, 6, 42))
    for i in range(6):  # reading_i = |R r_i + t - B_i| - l_i
        J[:, i, 7 * i:7 * i + 3] = np.einsum("nj,njk->nk", u[:, i], R)
        J[:, i, 7 * i + 3:7 * i + 6] = -u[:, i]
        J[:, i, 7 * i + 6] = -1.0
    twin = StewartSim(g, StewartTruth(hinge_error_mm=0.0, length_error_mm=0.0, station_offset_mm=0.0),
                      np.random.default_rng(0))
    loads = np.zeros(n) if load is None else load
    force = np.array([twin.leg_forces_n(R[k], t[k], loads[k]) for k in range(n)])
    if truth is not None and truth.has_leg_physics:
        res = res - leg_effects_mm(truth, L, force, rec.direction, rec.temp_c).ravel()
    drivers = {"L": L, "J_geo": J, "dir": rec.direction, "temp_c": rec.temp_c, "t_s": rec.t_s, "force": force}
    return drivers, res, frame


def stations(rec, tol_mm: float = 0.02, tol_rad: float = 2e-5) -> np.ndarray:
    """Station id (n,) per pose: the same place within the tolerances and, with directions,
    approached the same way by every leg."""
    from scipy.spatial import cKDTree
    from scipy.spatial.transform import Rotation

    rv = Rotation.from_matrix(rec.R).as_rotvec()
    key = np.c_[rec.t_mm / tol_mm, rv / tol_rad]
    if rec.direction is not None:
        key = np.c_[key, 1e6 * rec.direction]
    tree = cKDTree(key)
    ids = np.arange(len(key))
    for i, j in sorted(tree.query_pairs(1.0)):
        ids[j] = min(ids[j], ids[i])
    return np.unique(ids, return_inverse=True)[1].ravel()


def discover_stewart(rec, seed: int = 0, floor: float = STEWART_FLOOR, config=None) -> tuple[dict, dict]:
    """discovery.json's content for a Stewart recording, and what the figure needs."""
    from calibench.scenarios.discover import _describe, verdict
    from calibench.scenarios.stewart import StewartConfig
    from calibench.sim.stewart import leg_effects_mm

    config = config or StewartConfig()
    g = config.geometry
    n = len(rec)
    if n < 60:
        raise BadInput(f"{n} poses: discover stewart needs at least 60 (42 hinge parameters and the tracker's frame)")
    Rf, tf = register(rec, g)
    truth = config.truth if config.truth.has_leg_physics else None
    drivers, r, frame = twin_drivers(rec, g, Rf, tf, rec.load_n, truth)
    if truth is not None:  # register again with the twin's leg physics taken out of the readings
        import dataclasses

        own = leg_effects_mm(truth, drivers["L"], drivers["force"], rec.direction, rec.temp_c)
        Rf, tf = register(dataclasses.replace(rec, readings_mm=rec.readings_mm - own), g)
        drivers, r, frame = twin_drivers(rec, g, Rf, tf, rec.load_n, truth)
    sig = dsc.Signal("reading - twin", AXIS, r, frame, np.repeat(np.arange(n), 6))
    fold = np.minimum(np.arange(n) * 5 // n, 4)
    station = np.repeat(stations(rec), 6) * 6 + np.tile(np.arange(6), n)
    order = np.repeat(rec.t_s if rec.t_s is not None else np.arange(n, dtype=float), 6) + np.tile(np.arange(6), n) * 1e-3
    candidates = stewart_candidates(drivers)
    geo = next(c for c in candidates if c.name == "geometry")
    first = r - np.c_[frame, geo.columns(drivers)] @ dsc._lstsq(np.c_[frame, geo.columns(drivers)], r)
    noise = {AXIS: dsc.repeatability(first, station, order)}
    found, terms = dsc.select([sig], candidates, drivers, fold, noise, floor=floor)
    dsc.prune(sig, found, terms, drivers, fold, floor)
    effects, fitted = _describe([sig], terms, found, drivers, noise)
    after_noise = {AXIS: dsc.repeatability(fitted[AXIS], station, order)}
    confounded = []
    accepted = {t.key for t in terms[AXIS]}
    for c in candidates:
        if c.key in accepted or not hasattr(c, "columns") or c.name == "geometry":
            continue
        frac = dsc.confounded(sig, terms[AXIS], c, drivers, {})
        if frac > 0.9:
            confounded.append({"effect": c.name, "axis": AXIS, "with": "the hinge geometry and the accepted effects",
                               "why": f"{100 * frac:.0f} % of {c.key}'s effect on the readings is what the model "
                                      "already has", "experiment": EXPERIMENTS.get(c.name, "vary its driver")})
    names = [e["name"] for e in effects if e["name"] != "geometry"]
    out = {"scenario": "stewart", "samples": n, "unit": "mm", "located": [], "effects": effects,
           "fit": {"rms_nominal": float(np.sqrt(np.mean(r ** 2))), "cv_rms_nominal": found.cv_nominal,
                   "cv_rms_final": found.cv_final},
           "noise": {AXIS: {"repeatability_mm": noise[AXIS].sigma_mm, "lag1_correlation": noise[AXIS].lag1,
                            "dof": noise[AXIS].dof}},
           "noise_after_effects": {AXIS: {"repeatability_mm": after_noise[AXIS].sigma_mm,
                                          "dof": after_noise[AXIS].dof}},
           "holdout": "five contiguous blocks of poses",
           "scene_model": "the nominal platform (drawing hinges, rigid legs) at the tracker's poses, the tracker's "
                          "frame registered",
           "tracker_frame": {"R": Rf.tolist(), "t_mm": tf.tolist()},
           "temp_mean_c": None if rec.temp_c is None else float(np.mean(rec.temp_c)),
           "not_accepted": found.rejected, "confounded": confounded,
           "verdict": verdict(found.cv_final, after_noise, bool(names))}
    return out, {"signals": [sig], "fitted": fitted, "abscissa": (np.arange(len(r)) / 6, "pose (legs 1-6 each)")}
