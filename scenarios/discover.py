"""``calibench discover``: where a recording disagrees with the twin, and which physics is missing.

Stages (belt-stage, vision-stage): the twin replays the commands (``sim.replay``); the scene's
own error model (the belt stage's quadratic map, the vision stage's cubic one) is calibrated
with the data, as any user would; what is left is searched for missing effects. The arm: the
nominal chain replays the encoder readings; the chain's geometry is itself a candidate.

Writes DIR/discovery.json (CONTRACT) and DIR/discovery.png (residual maps before and after).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from calibench.estimators import discovery as dsc
from calibench.estimators.effects import (ArmThermalExpansion, EncoderEccentricity, Geometry, polynomial_candidates,
                                stage_candidates)
from calibench.scenarios.report import BadInput

STAGE_DEGREE = {"belt-stage": 2, "vision-stage": 3}
SUPPORTED = ("belt-stage", "vision-stage", "arm-cmm")
EXPERIMENTS = {
    "thermal_expansion": "let the machine's temperature change by several K during the test (or repeat it warm "
                         "and cold): only then does thermal expansion differ from a plain scale error",
    "thermal_drift": "hold the temperature steady for part of the test, or vary it independently of time",
    "backlash": "approach every station from both directions",
    "periodic": "measure at a finer step over a longer travel",
    "positioning": "measure more stations along the axis",
    "straightness": "measure more lines across the travel",
    "cross_coupling": "measure a full grid rather than lines",
}


def poly_base(x: np.ndarray, y: np.ndarray, degree: int, span: tuple[float, float]) -> np.ndarray:
    """The scene's error model as columns: monomials x^i y^j, i + j <= degree (scaled)."""
    u, v = x / max(span[0], 1e-9), y / max(span[1], 1e-9)
    return np.stack([u**i * v**(k - i) for k in range(degree + 1) for i in range(k + 1)], axis=1)


def folds_for(rec_run, x, y, holdout: str | None) -> tuple[np.ndarray, str]:
    """Fold label per sample: whole passes when there are several, else whole rows (or columns)
    of a grid, else five contiguous blocks in time."""
    if holdout in (None, "pass") and rec_run is not None and len(np.unique(rec_run)) >= 2:
        return np.unique(rec_run, return_inverse=True)[1], "leave one pass out"
    if holdout in (None, "rows") and len(np.unique(y)) <= len(y) / 4:
        return np.unique(y, return_inverse=True)[1], "leave one row (y) out"
    if holdout == "columns" and len(np.unique(x)) <= len(x) / 4:
        return np.unique(x, return_inverse=True)[1], "leave one column (x) out"
    return np.minimum(np.arange(len(x)) * 5 // len(x), 4), "five contiguous blocks"


# --- stages --------------------------------------------------------------------------------------
def discover_stage(scenario: str, rec, seed: int = 0, holdout: str | None = None,
                   floor: float = dsc.FLOOR) -> tuple[dict, dict]:
    """discovery.json's content for a stage recording, and what the figure needs."""
    from calibench.sim.replay import replay_stage

    n = len(rec)
    x, y = rec.x_cmd_mm, rec.y_cmd_mm
    if n < 20:
        raise BadInput(f"{n} stations: discover needs at least 20")
    sim = replay_stage(scenario, x, y)
    drivers = {"x": x, "y": y, "dir_x": rec.dir_x, "dir_y": rec.dir_y, "t_s": rec.t_s, "temp_c": rec.temp_c,
               "run": rec.run}
    span = (max(np.ptp(x), 1.0), max(np.ptp(y), 1.0))
    deg = STAGE_DEGREE[scenario]
    base = poly_base(x, y, deg, span)
    if np.linalg.matrix_rank(base) < base.shape[1]:
        raise BadInput(f"the stations do not span the {scenario} error model (degree {deg} in x and y): "
                       "measure a grid or lines along both axes")
    idx = np.arange(n)
    signals = [dsc.Signal("x_meas - x_sim", "x", rec.x_meas_mm - sim[:, 0], base, idx, x),
               dsc.Signal("y_meas - y_sim", "y", rec.y_meas_mm - sim[:, 1], base, idx, y)]
    fold, scheme = folds_for(rec.run, x, y, holdout)
    order = rec.t_s if rec.t_s is not None else idx.astype(float)
    dirs = [np.zeros(n) if d is None else d for d in (rec.dir_x, rec.dir_y)]
    key = np.unique(np.stack([x, y, *dirs], axis=1).round(6), axis=0, return_inverse=True)[1].ravel()
    noise = {s.axis: dsc.repeatability(s.r - base @ dsc._lstsq(base, s.r), key, order) for s in signals}
    step = np.median(np.diff(np.unique(np.r_[x, y]))) if len(np.unique(np.r_[x, y])) > 1 else 1.0
    candidates = stage_candidates(drivers)
    for a, u in (("x", x), ("y", y)):
        lo, hi = max(2.5 * step, 5.0), np.ptp(u) / 2
        if hi > lo:  # uniform in frequency, five points per resolution element (1 / travel)
            f = np.arange(1 / hi, 1 / lo, 1 / (5 * np.ptp(u)))
            candidates.append(dsc.PeriodSearch(a, 1 / f))
        candidates += polynomial_candidates(a, deg)
    found, terms = dsc.select(signals, candidates, drivers, fold, noise, floor=floor)

    # nonsmooth: what stands out of the repeatability after the accepted effects
    pos_key, pos_inv = np.unique(np.stack([x, y], axis=1).round(6), axis=0, return_inverse=True)
    pos_inv = pos_inv.ravel()
    for s in signals:
        table = dsc.find_nonsmooth(s, terms[s.axis], drivers, pos_inv, pos_key, noise[s.axis], fold, floor)
        if table is not None:
            cv_sq = {t.axis: float(np.sum(dsc.cv_residuals(t, terms[t.axis], drivers, fold, {}) ** 2))
                     for t in signals}
            before = np.sqrt(sum(cv_sq.values()) / (2 * n))
            cv_sq[s.axis] = float(np.sum(dsc.cv_residuals(s, terms[s.axis] + [table], drivers, fold, {}) ** 2))
            after = np.sqrt(sum(cv_sq.values()) / (2 * n))
            terms[s.axis].append(table)
            found.steps.append(dsc.Step(table, s.axis, float(before), float(after), 0.0))
            found.cv_final = float(after)

    effects, fitted = _describe(signals, terms, found, drivers, noise)
    located = _locate_stage(signals, drivers, seed)
    confounds = _confounds(signals, terms, found, candidates, drivers, rec)
    out = {"scenario": scenario, "samples": n, "unit": "mm", "located": located, "effects": effects,
           "fit": {"rms_nominal": found.rms_nominal, "cv_rms_nominal": found.cv_nominal,
                   "cv_rms_final": found.cv_final},
           "noise": {a: {"repeatability_mm": nz.sigma_mm, "lag1_correlation": nz.lag1, "dof": nz.dof}
                     for a, nz in noise.items()},
           "holdout": scheme, "scene_model": f"the twin plus its degree-{deg} error map in (x, y), calibrated",
           "not_accepted": found.rejected, "confounded": confounds}
    return out, {"signals": signals, "fitted": fitted, "x": x, "y": y}


def _describe(signals, terms, found, drivers, noise):
    """Each accepted effect's parameters and standard errors from the final all-data fit."""
    by_axis = {s.axis: s for s in signals}
    fitted, described = {}, {}
    for a, sig in by_axis.items():
        nz = noise.get(a)
        sigma = nz.sigma_mm * nz.inflation if nz is not None and nz.sigma_mm else None
        fixed, coef, cov, res = dsc.fit_terms(sig, terms[a], drivers, {}, sigma)
        fitted[a] = res
        for t, start, k in fixed:
            p, e, text = t.describe(coef[start:start + k], cov[start:start + k, start:start + k])
            described[t.key] = (t, p, e, text)
    effects = []
    for st in found.steps:
        key = st.term.key
        t, p, e, text = described[key]
        effects.append({"name": t.name, "axis": st.axis, "params": _plain(p), "stderr": _plain(e), "physics": text,
                        "cv_rms_before": st.cv_before, "cv_rms_after": st.cv_after})
    return effects, fitted


def _plain(d):
    return {k: (v if isinstance(v, str) or v is None else float(v) if not isinstance(v, (int, np.integer))
                else int(v)) for k, v in d.items()}


def _locate_stage(signals, drivers, seed):
    """Each residual (after the scene model) against each driver, whole-pass permutation tests."""
    rng = np.random.default_rng(seed)
    passes = drivers["run"] if drivers.get("run") is not None else np.zeros(len(signals[0].r))
    out = []
    for s in signals:
        r = s.r - s.base @ dsc._lstsq(s.base, s.r)
        for name in ("x", "y", "dir_x", "dir_y", "t_s", "temp_c"):
            v = drivers.get(name)
            if v is None or np.ptp(v) == 0:
                continue
            score, p = dsc.permutation_p(r, np.asarray(v, float), passes, name in ("t_s", "temp_c"), rng)
            if p > 0.01 or score < 0.02:
                continue
            out.append({"signal": s.name, "driver": name, "score": score, "p_value": p,
                        "where": _where(r, np.asarray(v, float), name, drivers)})
    return sorted(out, key=lambda d: -d["score"])


def _where(r, v, name, drivers):
    if name.startswith("dir_"):
        axis = name[-1]
        c, prof = dsc.reversal_profile(r, np.asarray(drivers[axis], float), v)
        ok = np.isfinite(prof)
        return (f"whole {axis.upper()} travel: forward minus backward {np.nanmean(prof) * 1000:+.1f} um "
                f"(from {np.nanmin(prof[ok]) * 1000:+.1f} to {np.nanmax(prof[ok]) * 1000:+.1f} um along it)")
    if name in ("t_s", "temp_c"):
        k, stat = dsc.change_point(r[np.argsort(drivers["t_s"])] if drivers.get("t_s") is not None else r)
        unit = "s" if name == "t_s" else "deg C"
        return f"follows {name} ({unit}); largest shift after sample {k} (CUSUM {stat:.1f})"
    edges = np.quantile(v, np.linspace(0, 1, 9))
    idx = np.clip(np.searchsorted(edges, v, side="right") - 1, 0, 7)
    means = np.array([np.mean(r[idx == k]) if np.any(idx == k) else 0 for k in range(8)])
    k = int(np.argmax(np.abs(means)))
    return f"largest at {name} {edges[k]:.0f}-{edges[k + 1]:.0f} mm (mean {means[k] * 1000:+.1f} um)"


def _confounds(signals, terms, found, candidates, drivers, rec):
    """Physical candidates the data cannot tell from what the model already has, each with the
    experiment that would (smooth polynomial terms are left out: they are meant to overlap)."""
    out = []
    by_axis = {s.axis: s for s in signals}
    accepted = {st.term.key for st in found.steps}
    for c in candidates:
        if c.key in accepted or isinstance(c, dsc.PeriodSearch) or c.name in ("positioning", "straightness",
                                                                              "cross_coupling"):
            continue
        frac = dsc.confounded(by_axis[c.axis], terms[c.axis], c, drivers, {})
        if c.name == "thermal_expansion" and np.ptp(rec.temp_c) < 1.0:
            out.append({"effect": c.name, "axis": c.axis, "with": "scale",
                        "why": f"the temperature moved only {np.ptp(rec.temp_c):.2f} K, so an expansion "
                               f"coefficient would look like (and be absorbed by) a scale error",
                        "experiment": EXPERIMENTS[c.name]})
        elif frac > 0.9:
            out.append({"effect": c.name, "axis": c.axis, "with": "the scene model and the accepted effects",
                        "why": f"{100 * frac:.0f} % of its effect on the data is also what the model already has",
                        "experiment": EXPERIMENTS.get(c.name, "vary its driver independently")})
    return out


# --- the arm ---------------------------------------------------------------------------------------
def discover_arm(rec, seed: int = 0, floor: float = dsc.FLOOR) -> tuple[dict, dict]:
    from calibench.estimators.arm_kinematics import PARAM_NAMES, DHChain, jacobian
    from calibench.scenes.arm_cmm import ArmGeometry
    from calibench.sim.replay import replay_arm

    n = len(rec.q_rad)
    if n < 40:
        raise BadInput(f"{n} postures: discover needs at least 40 for the arm's 25 parameters")
    g = ArmGeometry()
    chain = DHChain(np.array(g.a_mm, float), np.array(g.d_mm, float), np.array(g.alpha_rad, float))
    sim = replay_arm(rec.q_rad)
    J = jacobian(chain, rec.q_rad)
    drivers = {"q": rec.q_rad, "J": J, "a": np.array(g.a_mm, float), "d": np.array(g.d_mm, float),
               "temp_c": rec.temp_c, "t_s": rec.t_s}
    # the identifiable combinations of the 25 parameters, from the posture set
    Jf = J.reshape(-1, 25)
    scale = np.linalg.norm(Jf, axis=0)
    from scipy.linalg import qr

    _, R, piv = qr(Jf / scale, mode="economic", pivoting=True)
    rank = int(np.sum(np.abs(np.diag(R)) > 1e-6 * np.abs(R[0, 0])))
    kept = tuple(sorted(int(i) for i in piv[:rank]))
    geometry = Geometry(kept=kept, names=tuple(PARAM_NAMES[i] for i in kept))
    sig = dsc.Signal("xyz_meas - xyz_sim", "xyz", (rec.xyz_mm - sim).ravel(), np.zeros((3 * n, 0)),
                     np.repeat(np.arange(n), 3))
    candidates = [geometry] + [EncoderEccentricity(joint=j) for j in range(1, 7)]
    if rec.temp_c is not None and np.ptp(rec.temp_c) > 0:
        candidates.append(ArmThermalExpansion())
    fold = np.minimum(np.arange(n) * 5 // n, 4)
    noise = {"xyz": dsc.Noise(None, 0.0, 0)}
    found, terms = dsc.select([sig], candidates, drivers, fold, noise, floor=floor)
    effects, fitted = _describe([sig], terms, found, drivers, noise)
    # where: the residual after the geometry against each joint angle and the temperature
    located = []
    rng = np.random.default_rng(seed)
    geo = [t for t in terms["xyz"] if t.name == "geometry"]
    _, _, _, res = dsc.fit_terms(sig, geo, drivers, {}, None)
    res3 = res.reshape(n, 3)
    for name, v in [(f"q{j}", rec.q_rad[:, j - 1]) for j in range(1, 7)] + [("temp_c", rec.temp_c)]:
        if v is None or np.ptp(v) == 0:
            continue
        best = max((dsc.permutation_p(res3[:, k], v, np.zeros(n), name == "temp_c", rng, 99) + (k,)
                    for k in range(3)), key=lambda t: t[0])
        if best[1] <= 0.01 and best[0] >= 0.02:
            located.append({"signal": f"{'xyz'[best[2]]}_meas - {'xyz'[best[2]]}_sim (after geometry)",
                            "driver": name, "score": best[0], "p_value": best[1],
                            "where": f"over the whole range of {name}"})
    located.sort(key=lambda d: -d["score"])
    out = {"scenario": "arm-cmm", "samples": n, "unit": "mm", "located": located, "effects": effects,
           "fit": {"rms_nominal": float(np.sqrt(np.mean(sig.r**2))), "cv_rms_nominal": found.cv_nominal,
                   "cv_rms_final": found.cv_final},
           "holdout": "five contiguous blocks of postures",
           "scene_model": "the nominal DH chain (Table 1 drawing values)", "not_accepted": found.rejected,
           "confounded": []}
    return out, {"signals": [sig], "fitted": fitted}


def paper_belt_recording(data_dir: Path):
    """The seed paper's measured belt-stage tables (../shared/data/seed_belt_stage) as a stage
    recording: one row per station, error = measured - commanded (no passes, no directions)."""
    from calibench.recordings import StageRecording

    ex = np.loadtxt(Path(data_dir) / "x_axis_error_mm.csv", delimiter=",", skiprows=1)
    ey = np.loadtxt(Path(data_dir) / "y_axis_error_mm.csv", delimiter=",", skiprows=1)
    if not np.array_equal(ex[:, :2], ey[:, :2]):
        raise BadInput("the X and Y tables list different stations")
    x, y = ex[:, 0], ex[:, 1]
    return StageRecording(x_cmd_mm=x, y_cmd_mm=y, x_meas_mm=x + ex[:, 2], y_meas_mm=y + ey[:, 2])


# --- the command -----------------------------------------------------------------------------------
def run_discover(scenario: str, csv_path: Path, out_dir: Path, seed: int = 0, holdout: str | None = None) -> dict:
    from calibench.recordings import load_arm_csv, load_stage_csv

    if scenario not in SUPPORTED:
        raise BadInput(f"discover supports {', '.join(SUPPORTED)}, not {scenario!r}")
    if scenario == "arm-cmm":
        out, fig = discover_arm(load_arm_csv(csv_path), seed)
    else:
        out, fig = discover_stage(scenario, load_stage_csv(csv_path), seed, holdout)
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / "discovery.json").write_text(json.dumps(out, indent=2, default=_json_default) + "\n")
    _figure(out_dir / "discovery.png", out, fig)
    return out


def _json_default(o):
    if isinstance(o, (np.floating, np.integer)):
        return o.item()
    raise TypeError(type(o))


def _figure(path: Path, out: dict, fig: dict) -> None:
    """Residuals before (the scene model alone) and after (with the accepted effects)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    sigs = fig["signals"]
    f, axes = plt.subplots(len(sigs), 2, figsize=(13, 3.6 * len(sigs)), squeeze=False, constrained_layout=True)
    for row, s in zip(axes, sigs):
        before = s.r - s.base @ dsc._lstsq(s.base, s.r) if s.base.shape[1] else s.r
        after = fig["fitted"][s.axis]
        if "x" in fig and s.u is not None:
            for ax, v, title in ((row[0], before, "scene model only"), (row[1], after, "with the accepted effects")):
                lim = np.max(np.abs(before)) * 1000
                sc = ax.scatter(fig["x"], fig["y"], c=v * 1000, s=6, cmap="coolwarm", vmin=-lim, vmax=lim)
                ax.set(title=f"{s.name}: {title}, rms {np.sqrt(np.mean(v**2)) * 1000:.2f} um",
                       xlabel="x (mm)", ylabel="y (mm)")
                f.colorbar(sc, ax=ax, label="um")
        else:
            for ax, v, title in ((row[0], before, "nominal chain"), (row[1], after, "with the accepted effects")):
                ax.plot(v * 1000, ".", ms=2)
                ax.set(title=f"{s.name}: {title}, rms {np.sqrt(np.mean(v**2)) * 1000:.1f} um",
                       xlabel="row (posture x 3 + coordinate)", ylabel="um")
    f.suptitle(f"{out['scenario']}: " + (", ".join(f"{e['name']} ({e['axis']})" for e in out["effects"]) or "nothing missing"))
    f.savefig(path, dpi=80)
    plt.close(f)
