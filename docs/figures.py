"""The README's numbers, generated: ``python docs/figures.py`` (or ``make figures``).

Every table or sentence of README.md that reports what calibench computes sits between two marker
lines, ``<!-- figures:NAME -->`` and ``<!-- /figures:NAME -->``. Each NAME is a block here: a
function that runs the calibench command or Python API behind those numbers (every one
deterministic from its seed) and returns the block's markdown. The markers stay; the text between
them is rewritten.

    python docs/figures.py                    # rewrite every block of README.md
    python docs/figures.py NAME...            # rewrite these blocks only
    python docs/figures.py --check [NAME...]  # regenerate and compare with README.md: each number
                                              # beyond its block's tolerance is printed, exit 1
    python docs/figures.py --list             # the blocks, what each runs, its time on 2 cores

``make figures`` and ``make figures-check`` run the first and the third (FIGURES="NAME ..." for
some blocks); tests/test_readme_figures.py checks the blocks marked ``ci`` (the fast ones).

The check compares numbers, not words: the numbers of both texts are parsed in order and paired;
a block whose count of numbers differs, or a pair beyond the block's tolerance, is a disagreement.
Numbers that are machine timings (trials/s, seconds per run) are not generated: they stay typed
in the README, outside the blocks, with the machine and benchmark they came from.

The real-data blocks read ../shared/data (beside the repository). Runs go to a scratch folder.
"""

from __future__ import annotations

import argparse
import contextlib
import dataclasses
import functools
import io
import json
import math
import os
import re
import sys
import tempfile
import textwrap
import time
from pathlib import Path
from typing import Callable

os.environ.setdefault("MUJOCO_GL", "egl")  # before MuJoCo's first import: renders without a display

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
DATA = ROOT.parent / "shared" / "data"
UR10 = DATA / "ur10_landgraf"


# --- the registry --------------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class Block:
    """One generated span of the README.

    Attributes
    ----------
    name : str
        The marker's name.
    make : callable
        Returns the block's markdown (no marker lines, no indentation).
    seconds : float
        Expected run time on its own (2 cores); blocks that share a run cost less together.
    ci : bool
        Fast enough for the test suite (tests/test_readme_figures.py); the others are checked
        by ``make figures-check``.
    rel : float
        Tolerance relative to the README's number (Monte-Carlo studies, renders).
    last_digit : float
        Tolerance in units of the README number's last printed digit (0: the printed digits must
        agree exactly).
    """

    name: str
    make: Callable[[], str]
    seconds: float
    ci: bool
    rel: float = 0.0
    last_digit: float = 0.0

    @property
    def what(self) -> str:
        """The first paragraph of the block function's docstring: what it runs."""
        return " ".join((self.make.__doc__ or "").split("\n\n")[0].split())


BLOCKS: dict[str, Block] = {}


def block(seconds: float, ci: bool, rel: float = 0.0, last_digit: float = 0.0):
    """Register the decorated function as the block named after it (underscores as dashes)."""

    def register(fn):
        name = fn.__name__.replace("_", "-")
        BLOCKS[name] = Block(name, fn, seconds, ci, rel, last_digit)
        return fn

    return register


# --- running calibench -----------------------------------------------------------------------------
_SCRATCH: list = []  # the scratch folder, removed when the process ends


def scratch() -> Path:
    """One scratch folder per process for every command's output."""
    if not _SCRATCH:
        _SCRATCH.append(tempfile.TemporaryDirectory(prefix="calibench-figures-"))
    return Path(_SCRATCH[0].name)


def calibench(*args) -> None:
    """Run one ``calibench`` command in this process, its printout kept back unless it fails."""
    from calibench.scenarios.cli import main

    argv = [str(a) for a in args]
    out = io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(out):
        status = main(argv)
    if status != 0:
        raise RuntimeError(f"calibench {' '.join(argv)} exited {status}:\n{out.getvalue()}")


def need_data(*paths: Path) -> None:
    """The real-data blocks need ../shared/data beside the repository."""
    missing = [p for p in paths if not p.exists()]
    if missing:
        raise RuntimeError(f"missing {', '.join(map(str, missing))} (the shared data lives in ../shared/data)")


@functools.cache
def report(scenario: str) -> dict:
    """``calibench run SCENARIO --seed 0`` (default fidelity, render where the scenario renders):
    its report.json."""
    out = scratch() / "run" / scenario
    calibench("run", scenario, "--seed", 0, "--out", out, "--no-rrd")
    return json.loads((out / "report.json").read_text())


def checks(scenario: str) -> dict:
    """The run's checks by name."""
    return {c["name"]: c for c in report(scenario)["checks"]}


def params(scenario: str) -> dict:
    """The run's parameters by name."""
    return {p["name"]: p for p in report(scenario)["parameters"]}


def series(*letters: str) -> list[Path]:
    """The UR10's recordings ur10_X.csv."""
    paths = [UR10 / f"ur10_{x}.csv" for x in letters]
    need_data(UR10 / "ur10.toml", *paths)
    return paths


@functools.cache
def ur10_fit(setup: str, effects: str | None = None, model: str | None = None) -> dict:
    """``calibench fit arm-cmm`` on the real UR10: its fit.json. ``setup`` "C": trained on C,
    tested on B (C's frame), A and D (new frames); "all": trained on all four, 30 % held out.
    ``effects``: a file for ``--effects`` (``"discovery-C"``: the discovery on C)."""
    out = scratch() / "fit" / f"{setup}-{model}-{Path(effects or 'none').stem}"
    args = ["fit", "arm-cmm"]
    if setup == "C":
        c, b, a, d = series("C", "B", "A", "D")
        args += [c, "--test", b, "--test-new-frame", a, "--test-new-frame", d]
    else:
        args += [*series("C", "B", "A", "D"), "--holdout", 0.3]
    args += ["--arm", UR10 / "ur10.toml", "--out", out]
    if model:
        args += ["--model", model]
    if effects == "discovery-C":
        args += ["--effects", ur10_discovery_c_json()]
    elif effects:
        args += ["--effects", ROOT / effects]
    calibench(*args)
    return json.loads((out / "fit.json").read_text())


@functools.cache
def ur10_discovery_c_json() -> Path:
    """``calibench discover arm-cmm ur10_C.csv --arm ur10.toml``: its discovery.json's path."""
    out = scratch() / "discover" / "ur10_C"
    calibench("discover", "arm-cmm", *series("C"), "--arm", UR10 / "ur10.toml", "--out", out)
    return out / "discovery.json"


def ur10_discovery_c() -> dict:
    """The discovery on ur10_C (discovery.json's content)."""
    return json.loads(ur10_discovery_c_json().read_text())


# --- formatting --------------------------------------------------------------------------------------
def span(values, fmt: str = ".3f", sep: str = "-") -> str:
    """'lo-hi' of the values (one value if they print the same)."""
    lo, hi = format(min(values), fmt), format(max(values), fmt)
    return lo if lo == hi else f"{lo}{sep}{hi}"


def ranges(pairs) -> str:
    """[[37, 76], [78, 78], [80, 80]] as '37-76, 78 and 80'."""
    parts = [str(a) if a == b else f"{a}-{b}" for a, b in pairs]
    return parts[0] if len(parts) == 1 else ", ".join(parts[:-1]) + " and " + parts[-1]


def words(items) -> str:
    """'a', 'a and b', 'a, b and c'."""
    items = list(items)
    return items[0] if len(items) == 1 else ", ".join(items[:-1]) + " and " + items[-1]


def table(header: list[str], rows: list[list[str]]) -> str:
    """A markdown table."""
    def row(cells):
        return "|" + "|".join(f" {c} " if c else " " for c in cells) + "|"

    return "\n".join([row(header), "|" + "---|" * len(header)] + [row(r) for r in rows])


def bold_least(cells: list[float], fmt: str) -> list[str]:
    """The values formatted, the least in bold."""
    best = min(cells)
    return [f"**{v:{fmt}}**" if v == best else f"{v:{fmt}}" for v in cells]


# --- belt-stage ----------------------------------------------------------------------------------------
@block(seconds=15, ci=True, last_digit=1)
def belt_stage():
    """calibench run belt-stage --seed 0 (render): the figures against their limits."""
    c, p, info = checks("belt-stage"), params("belt-stage"), report("belt-stage")["info"]
    intr = [p[n] for n in ("fx", "fy", "cx", "cy")]
    off = max(abs(q["estimate"] - q["truth"]) for q in intr)
    tol = min(q["tolerance"] for q in intr)
    return table(["figure", "value", "limit"], [
        ["corner_rms_px (detected vs exact projection, through the lens)", f"{c['corner_rms_px']['value']:.3f}",
         f"{c['corner_rms_px']['limit']:g}"],
        ["map_rms_mm (estimated vs true map over the whole travel)", f"{c['map_rms_mm']['value']:.3f}",
         f"{c['map_rms_mm']['limit']:g}"],
        ["check_rms_before_mm / check_rms_after_mm",
         f"{c['check_rms_before_mm']['value']:.2f} / {c['check_rms_after_mm']['value']:.3f}",
         f"- / {c['check_rms_after_mm']['limit']:g}"],
        ["fx, fy, cx, cy against the truth",
         f"within {off:.3f} px (std {span([q['std'] for q in intr])})",
         f"5 std, at least {tol:g} px"],
        ["the paper's own travel method on the same images", f"map error {info['paper_method']['map_rms_mm']:.1f} mm",
         ""],
    ])


# --- vision-stage ----------------------------------------------------------------------------------------
@block(seconds=40, ci=False, last_digit=1)
def vision_stage():
    """calibench run vision-stage --seed 0 (render): the interferometer's largest deviations."""
    from calibench.sim.vision_stage import VisionStageTruth

    c, info = checks("vision-stage"), report("vision-stage")["info"]
    best = info["best_model"]
    injected = VisionStageTruth().x.pos.period
    return table(["largest \\|positioning deviation\\| (interferometer, both axes)", "calibench", "the paper"], [
        ["uncompensated", f"{c['pos_error_uncompensated_um']['value']:.1f} um", "about 60 um"],
        ["line rulers, piecewise linear (Eq. 3-4)", f"{c['pos_error_lineruler_um']['value']:.1f} um", "about +-5 um"],
        ["cubic bivariate polynomial (Eq. 5-9)", f"{c['pos_error_polynomial_um']['value']:.1f} um", "about +-2 um"],
        [f"cross-validated model (here: X: {best['x']} ({injected:g} mm injected); Y: {best['y']})",
         f"{c['pos_error_best_um']['value']:.1f} um", ""],
    ])


@block(seconds=40, ci=False, last_digit=1)
def vision_stage_alignment():
    """calibench run vision-stage --seed 0 (render): circle centres and the plate's alignment."""
    c, info = checks("vision-stage"), report("vision-stage")["info"]
    est, truth = info["phi_estimates_urad"], info["phi_truths_urad"]
    return (f"On seed 0's renders the circle centres are {c['circle_centre_rms_px']['value']:.3f} px RMS from the "
            f"exact image of the centre. Plate angle: {est[0]:.0f} urad measured against {truth[0]:.0f} true, "
            f"{c['phi_residual_urad']['value']:.1f} urad left after {len(est) - 1} turns.")


# --- probe-scanner ----------------------------------------------------------------------------------------
@block(seconds=5, ci=True)
def probe_scanner():
    """calibench run probe-scanner --seed 0: the paper's method against least squares."""
    from calibench.scenarios.registry import SCENARIOS

    p, c = params("probe-scanner"), checks("probe-scanner")
    samples = SCENARIOS["probe-scanner"].config().geometry.samples_per_turn

    def pm(name, fmt):
        return f"{p[name]['estimate']:{fmt}} +- {p[name]['std']:{fmt}}"

    return table(["", f"d (truth {p['d_lsq']['truth']:.3f} mm)", f"dL ({p['dL_lsq']['truth']:.3f} mm)",
                  f"alpha0 ({p['alpha0_lsq']['truth']:.1f} mrad)"], [
        [f"paper's method, m = {c['paper_m']['value']:.0f}", f"{p['d_paper']['estimate']:.2f}",
         f"{p['dL_paper']['estimate']:.2f}", f"{p['alpha0_paper']['estimate']:.1f}"],
        [f"least squares on all {samples} samples, with the plate centre", pm("d_lsq", ".4f"), pm("dL_lsq", ".4f"),
         pm("alpha0_lsq", ".2f")],
    ])


@block(seconds=5, ci=True)
def probe_scanner_sweep():
    """calibench run probe-scanner --seed 0: the window m that meets the requirement, the rim."""
    from calibench.scenarios.registry import SCENARIOS

    config = SCENARIOS["probe-scanner"].config()
    info, c = report("probe-scanner")["info"], checks("probe-scanner")
    return (f"Over {config.sweep_turns} turns the paper's method meets the {info['requirement_mm']:g} mm requirement "
            f"for m = {ranges(info['m_meeting_requirement_rms_over_turns'])} (the paper: about 40-60). The spectacle "
            f"rim traced with the design values is {c['contour_rms_before_mm']['value']:.2f} mm RMS off its true "
            f"outline; with the full-data calibration {c['contour_rms_after_mm']['value']:.4f} mm (half an encoder "
            f"step); with the paper's, {c['contour_rms_paper_mm']['value']:.3f} mm.")


# --- arm-cmm ------------------------------------------------------------------------------------------------
@block(seconds=4, ci=True)
def arm_cmm_dropped():
    """calibench run arm-cmm --seed 0: the parameters the tracker's data cannot tell apart."""
    dropped = report("arm-cmm")["info"]["dropped_tracker"]
    like = {k: v.removeprefix("moves the data as ").split(" (")[0] for k, v in dropped.items()}
    betas = sorted(k for k in like if k.startswith("dbeta"))
    rest = {k: v for k, v in like.items() if k not in betas}
    frame = [f"{k} (= {v})" for k, v in rest.items() if not v.startswith("tool_")]
    tool = sorted(k for k, v in rest.items() if v.startswith("tool_"))
    n_joints = len(report("arm-cmm")["info"]["injected_delta"]) // 5  # da, dd, dalpha, dtheta, dbeta a joint
    parts = [", ".join(frame)] * bool(frame) + [f"{words(tool)}, which the tool absorbs"] * bool(tool)
    parts += ["every beta (no two of its axes are parallel, so beta repeats DH's own parameters)"
              if len(betas) == n_joints else words(betas)] * bool(betas)
    parts[-1] = "and " + parts[-1] if len(parts) > 1 else parts[-1]
    return (f"Dropped for the seed's arm from tracker data ({len(dropped)}), each with what it moves the data as: "
            f"{'; '.join(parts)}.")


@block(seconds=4, ci=True)
def arm_cmm_postures():
    """calibench run arm-cmm --seed 0: the observability of the chosen postures."""
    from calibench.scenarios.registry import SCENARIOS

    c, n = checks("arm-cmm"), SCENARIOS["arm-cmm"].config().n_postures
    return (f"{c['observability_chosen']['value']:.1f} against {c['observability_random']['value']:.1f} for "
            f"{n} random postures.")


@block(seconds=4, ci=True)
def arm_cmm_whitened():
    """calibench run arm-cmm --seed 0: the identification's whitened residual RMS."""
    return f"On seed 0 the whitened residual RMS is {report('arm-cmm')['info']['whitened_rms_tracker']:.2f}."


@functools.cache
def arm_coverage(factor: float, trials: int) -> tuple[float, float]:
    """The 95 % coverage of the seed arm's identification over ``trials`` truths drawn from its
    prior, with the datasheet's sigma ``factor`` x the truth's: as reported (with the variance
    factor), and without it (the std divided by the whitened RMS)."""
    import numpy as np

    from calibench.estimators.arm_identification import identify_identifiable
    from calibench.scenarios.arm_cmm import ArmCmmConfig, prior, reference_values, tracker_problem
    from calibench.scenarios.arms import chain_of
    from calibench.sim.arm_cmm import ArmSim

    base = ArmCmmConfig()
    stated = dataclasses.replace(base, stated_range_sigma_um=tuple(factor * x for x in base.stated_range_sigma_um),
                                 stated_angle_sigma_urad=factor * base.stated_angle_sigma_urad,
                                 stated_encoder_sigma_urad=factor * base.stated_encoder_sigma_urad)
    z, z_raw = [], []
    for seed in range(trials):  # the test's draws (tests/scenarios/test_arm_cmm.py), seed for seed
        config = prior(stated, np.random.default_rng(10_000 + seed))
        # the Monte-Carlo unit (scenarios.arm_cmm.trial_parameters) up to the identification
        rng = np.random.default_rng(seed)
        sim = ArmSim(config.arm, config.truth)
        q = sim.random_postures(config.n_postures, rng)
        ident = identify_identifiable(tracker_problem(sim, chain_of(sim.arm), q, sim.encoders(q, rng), rng,
                                                      config.stated))
        ref = reference_values(sim.arm, sim.delta, list(ident.estimate), ident.basis.partners)
        for name, value in ref.items():
            err = ident.estimate[name] - value
            z.append(err / ident.std[name])
            z_raw.append(err / (ident.std[name] / ident.rms))
    return float(np.mean(np.abs(z) <= 1.96)), float(np.mean(np.abs(z_raw) <= 1.96))


@block(seconds=16, ci=True)
def arm_cmm_datasheet():
    """The seed arm's 95 % coverage with the datasheet's sigma 1.5x off either way, 200 trials each
    (the recipe of tests/scenarios/test_arm_cmm.py)."""
    trials = 200
    big, small = arm_coverage(1.5, trials), arm_coverage(1 / 1.5, trials)
    return (f"The covariance carries the variance factor the residuals show, so with the datasheet 1.5x too large "
            f"or too small the 95 % intervals still cover {span([big[0], small[0]])} of the errors over {trials} "
            f"trials each way ({big[1]:.3f} and {small[1]:.3f} without the factor; a test checks the former).")


@block(seconds=4, ci=True)
def arm_cmm():
    """calibench run arm-cmm --seed 0: held-out probe positions."""
    from calibench.scenarios.registry import SCENARIOS

    c, n = checks("arm-cmm"), SCENARIOS["arm-cmm"].config().n_holdout
    return table([f"held-out probe positions ({n} postures), `calibench run arm-cmm`", "RMS error"], [
        ["nominal model", f"{c['probe_rms_before_mm']['value']:.2f} mm"],
        ["identified, chosen postures", f"{c['probe_rms_after_mm']['value']:.4f} mm"],
        ["identified, random postures", f"{c['probe_rms_after_random_mm']['value']:.4f} mm"],
        ["cones and bar alone (after a rigid fit: no base frame)", f"{c['probe_rms_after_cone_mm']['value']:.4f} mm"],
    ])


# --- the real UR10 --------------------------------------------------------------------------------------------
def _rows(rows: list[int]) -> str:
    return ("row " if len(rows) == 1 else "rows ") + words([str(r) for r in sorted(rows)])


@block(seconds=10, ci=True)
def ur10_left_out():
    """calibench fit arm-cmm ur10_C.csv --test ur10_B.csv ... --model physics: the rows left out."""
    parts = []
    for name, rows in ur10_fit("C", model="physics")["flagged"].items():
        who = name.removeprefix("ur10_").removesuffix(".csv")
        kinds = {"beyond the fit's scatter": [r["row"] for r in rows if r["why"].startswith("its residual")],
                 "stale": [r["row"] for r in rows if r["why"].startswith("stale")],
                 "the farther of a repeat that disagrees": [r["row"] for r in rows
                                                            if r["why"].startswith("the same posture")]}
        parts.append(f"{who}'s " + words([f"{_rows(v)} ({k})" for k, v in kinds.items() if v]))
    return f"Left out by the physics fit on C below: {'; '.join(parts)}."


@block(seconds=15, ci=True)
def ur10_trained_on_c():
    """calibench fit arm-cmm ur10_C.csv --test B --test-new-frame A --test-new-frame D, --model
    geometry and physics."""
    geo, phys = ur10_fit("C", model="geometry"), ur10_fit("C", model="physics")
    joints = [n["name"].removeprefix("compliance") for n in phys["parameters"] if n["name"].startswith("compliance")]
    cols = ["ur10_B.csv", "ur10_A.csv", "ur10_D.csv"]
    g = [geo["test"][c]["mean_mm"] for c in cols]
    p = [phys["test"][c]["mean_mm"] for c in cols]
    best = [bold_least([a, b], ".3f") for a, b in zip(g, p)]
    return table(["trained on C", "B (same frame)", "A (new frame)", "D (new frame)"], [
        # not a calibench run: the issue's own figures, for comparison
        ["rigid registration alone (the issue's figures)", "1.0-1.8", "0.75", "0.93"],
        ["`--model geometry`", *[b[0] for b in best]],
        [f"`--model physics` (joints {words(joints)} compliant under the twin's gravity)", *[b[1] for b in best]],
    ])


@block(seconds=15, ci=True)
def ur10_coverage():
    """calibench fit arm-cmm ur10_C.csv ..., --model geometry and physics: the fits on C itself, and the
    coverage check's words."""
    geo, phys = ur10_fit("C", model="geometry"), ur10_fit("C", model="physics")
    warn = phys["coverage"]["warnings"]
    one_way = next(w for w in warn if w.startswith("joint 2's gravity torque"))
    share = re.search(r"(\d+) %", one_way).group(1)
    other = next(w for w in warn if w.startswith("ur10_D.csv") and "load joint 2" in w)
    return (f"The geometry fits C as well as physics does ({geo['fit']['mean_mm']:.3f} against "
            f"{phys['fit']['mean_mm']:.3f} mm on C itself), but C's random poses hold the shoulder's gravity torque "
            f"one way ({share} % of them): the coverage check says so (\"{other}\"), and only the compliance "
            f"carries the fit to B, A and D.")


ALL = ("ur10_C.csv", "ur10_B.csv", "ur10_A.csv", "ur10_D.csv")
GEAR = "docs/ur10_gear_harmonics.json"
H17 = "docs/ur10_harmonic17.json"


def _effects_words(d: dict) -> str:
    """A discovery's joint-angle effects in words: 'gear harmonics of joints 1-3, a table over q2'."""

    def joints(name):
        js = sorted(e["params"]["joint"] for e in d["effects"] if e["name"] == name)
        if len(js) > 2 and js == list(range(js[0], js[-1] + 1)):
            return f"joints {js[0]}-{js[-1]}"
        return ("joint " if len(js) == 1 else "joints ") + words(map(str, js)) if js else ""

    out = [f"{what} of {joints(name)}" for name, what in (("transmission", "gear harmonics"),
                                                           ("encoder_eccentricity", "eccentricity")) if joints(name)]
    tables = sorted(e["params"]["joint"] for e in d["effects"] if e["name"] == "nonsmooth")
    return ", ".join(out + [f"a table over q{j}" for j in tables])


@block(seconds=300, ci=False)
def ur10_all_four():
    """calibench fit arm-cmm on all four series, --holdout 0.3: physics, with the discovery on C's
    effects (calibench discover arm-cmm ur10_C.csv) and with per-session gear harmonics."""
    fits = [ur10_fit("all"), ur10_fit("all", "discovery-C"), ur10_fit("all", GEAR)]
    means = [[f["holdout"][c]["mean_mm"] for c in ALL] for f in fits]
    maxes = [[f["holdout"][c]["max_mm"] for c in ALL] for f in fits]
    cells = [[] for _ in fits]
    for k in range(len(ALL)):
        a = bold_least([m[k] for m in means], ".3f")
        b = bold_least([round(m[k], 2) for m in maxes], ".2f")
        for i in range(len(fits)):
            both = a[i].startswith("**") and b[i].startswith("**")
            cells[i].append(f"**{a[i].strip('*')} / {b[i].strip('*')}**" if both else f"{a[i]} / {b[i]}")
    return table(["trained on all four, 30 % held out (mean / max, mm)", "C", "B", "A", "D"], [
        ["`--model physics`", *cells[0]],
        [f"with the effects discovery found on C ({_effects_words(ur10_discovery_c())})", *cells[1]],
        [f"with gear harmonics whose phase each session sets (`--effects {GEAR}`)", *cells[2]],
    ])


@block(seconds=90, ci=False)
def ur10_one_phase():
    """calibench fit arm-cmm on all four, --holdout 0.3, without and with --effects
    docs/ur10_harmonic17.json (one phase for all series)."""
    plain, h17 = ur10_fit("all")["holdout"], ur10_fit("all", H17)["holdout"]
    order = ("ur10_A.csv", "ur10_D.csv", "ur10_B.csv", "ur10_C.csv")
    better = [c for c in order if h17[c]["mean_mm"] < plain[c]["mean_mm"]]
    worse = [c for c in order if c not in better]
    moves = [f"{c[5]} from {plain[c]['mean_mm']:.3f} to {h17[c]['mean_mm']:.3f}" for c in better + worse]
    if moves:
        moves[0] += " mm"
    text = f"With one phase for all series (`--effects {H17}`) it brings {words(moves[:len(better)])}"
    if worse:
        text += f", but {words(moves[len(better):])}: {words([c[5] for c in worse])}'s phase differs"
    return text + "."


@block(seconds=120, ci=False)
def ur10_per_session():
    """calibench fit arm-cmm on all four, --holdout 0.3 --effects docs/ur10_gear_harmonics.json."""
    spec = json.loads((ROOT / GEAR).read_text())
    harmonics = sorted({h for e in spec["effects"] for h in e["params"]["harmonics"]})
    joints = sorted(e["params"]["joint"] for e in spec["effects"])
    held = ur10_fit("all", GEAR)["holdout"]
    worst = max(ALL, key=lambda c: held[c]["max_mm"])
    rest = max(held[c]["max_mm"] for c in ALL if c != worst)
    return (f"`{GEAR}` holds {words(map(str, harmonics))} cycles per turn on joints {joints[0]}-{joints[-1]} (17 "
            f"from the periodograms, 12 and 20 from discovery on C): every held-out mean falls to "
            f"{span([held[c]['mean_mm'] for c in ALL], '.2f')} mm and every max but {worst[5]}'s to {rest:.2f} mm or "
            f"less; {worst[5]}'s is {held[worst]['max_mm']:.2f} mm.")


@block(seconds=150, ci=False)
def ur10_targets():
    """The issue's targets (0.40 mm mean, 1.3 mm max on C; 0.25 mm the aim) against the physics fit
    on all four and the fit with per-session gear harmonics."""
    mean_t, max_t, aim = 0.40, 1.3, 0.25  # the issue's targets
    c = ur10_fit("all")["holdout"]["ur10_C.csv"]
    held = ur10_fit("all", GEAR)["holdout"]
    at = "is at" if c["mean_mm"] <= mean_t and c["max_mm"] <= max_t else "is not at"
    under = [x for x in ALL if held[x]["mean_mm"] < mean_t]
    over = [x for x in ALL if held[x]["max_mm"] >= max_t]
    means = "every series is" if len(under) == len(ALL) else f"{words([x[5] for x in under])} are"
    maxes = f"every max under {max_t} mm" + (f" but {words([x[5] + chr(39) + 's' for x in over])} "
                                             f"({words([format(held[x]['max_mm'], '.2f') for x in over])})"
                                             if over else "")
    a = held["ur10_A.csv"]["mean_mm"]
    return (f"Where that leaves the issue's targets: the physics model alone {at} {mean_t:.2f} / {max_t} mm on C "
            f"({c['mean_mm']:.3f} / {c['max_mm']:.2f}); with the per-session gear harmonics {means} under "
            f"{mean_t:.2f} mm mean and {maxes}, and A is {'under' if a < aim else 'not under'} the {aim} mm aim.")


@block(seconds=150, ci=False)
def ur10_discovery():
    """calibench discover arm-cmm ur10_C.csv --arm ur10.toml: the held-out RMS, effect by effect."""
    d = ur10_discovery_c()
    steps, gears = [], []  # a run of gear harmonics reads as one step: "of joint 2 (...), of joint 1 (...)"
    for e in d["effects"] + [{"name": "end"}]:
        p = e.get("params", {})
        um = f"{e['cv_rms_after'] * 1000:.0f} um" if "cv_rms_after" in e else ""
        if e["name"] == "transmission":
            amp = max(p["amplitude_urad"]) if isinstance(p["amplitude_urad"], list) else p["amplitude_urad"]
            unit = " cycles per turn" if not gears else ""
            gears.append(f"of joint {p['joint']} ({amp:.0f} urad, {p['harmonics'][0]:.2f}{unit}) {um}")
            continue
        if gears:
            steps.append("gear harmonics " + words(gears))
            gears = []
        if e["name"] == "geometry":
            steps.append(f"with its geometry {um}")
        elif e["name"] == "nonsmooth":
            where = re.sub(r"^as a function of q\d+, ", "", p["where"])
            steps.append(f"a table over joint {p['joint']}'s angle (nonsmooth: {where}, {p['peak_urad']:+.0f} urad) "
                         f"{um}")
        elif e["name"] != "end":
            steps.append(f"{e['name'].replace('_', ' ')} of joint {p.get('joint')} {um}")
    comp = [c for c in d["confounded"] if c["effect"] == "joint_compliance"]
    joints = [re.search(r"joint (\d+)'s", c["why"]).group(1) for c in comp]
    absorbed = [int(re.search(r"(\d+) % of a compliance", c["why"]).group(1)) for c in comp]
    torque = next((map(int, re.search(r"\((-?\d+) to (-?\d+) N m\)", c["why"]).groups()) for c in comp
                   if "joint 2's" in c["why"]), None)
    text = (f"(held-out RMS per coordinate, {d['holdout']}): the drawing's UR10 "
            f"{d['fit']['cv_rms_nominal'] * 1000:.0f} um; {'; '.join(steps)}.")
    if comp:
        text += (f" The compliances of joints {words(joints)} are not claimed from C alone, and discovery says why in "
                 f"words: within C's poses the geometry absorbs {span(absorbed, 'd')} % of their effect"
                 + (" (C holds joint 2's torque at {} to {} N m)".format(*torque) if torque else "")
                 + ", though compliance is what carries the fit to the other series.")
    return text


# --- stewart ----------------------------------------------------------------------------------------------------
@block(seconds=3, ci=True, last_digit=9)  # a gap at rounding level: any value under 1e-9 um agrees
def stewart_closure():
    """calibench run stewart --seed 0: the loop closure of MuJoCo's soft constraints."""
    return (f"MuJoCo's constraints are soft, so every pose is set from closed-form inverse kinematics and the loop "
            f"closure is measured: {checks('stewart')['loop_closure_um']['value']:.0e} um at worst on seed 0.")


@block(seconds=3, ci=True)
def stewart_stations():
    """calibench run stewart --seed 0: the stations' errors against their propagated std."""
    info = report("stewart")["info"]
    predicted = [s for station in info["station_sigma_um"] for s in station]
    return (f"Station errors {span(info['station_error_um'], '.0f')} um against {span(predicted, '.0f')} um "
            f"predicted per axis on seed 0.")


@block(seconds=3, ci=True)
def stewart_one_step():
    """calibench run stewart --seed 0: the one-step calibration."""
    info, p = report("stewart")["info"], report("stewart")["parameters"]
    ok = sum(q["ok"] for q in p)
    within = f"all {len(p)}" if ok == len(p) else f"{ok} of {len(p)}"
    return (f"On seed 0 the legs' Gauss-Newton alone is {info['pipeline_rms_error_mm']:.3f} mm RMS off the truth; "
            f"the joint adjustment has {within} within 5 std of it, whitened RMS {info['whitened_rms']:.2f}.")


@block(seconds=3, ci=True)
def stewart_two_step():
    """calibench run stewart --seed 0: the two-step calibration's parameter error."""
    return f"{report('stewart')['info']['compare_rms_error_mm']['two_step']:.2f} mm RMS error on seed 0."


@block(seconds=3, ci=True)
def stewart():
    """calibench run stewart --seed 0: held-out poses."""
    c = checks("stewart")
    n = re.match(r"(\d+)", c["pose_rms_before_um"]["note"]).group(1)
    return table([f"held-out poses ({n}), from the legs' readings", "RMS error at the hinges"], [
        ["nominal parameters", f"{c['pose_rms_before_um']['value']:.0f} um"],
        ["one-step calibration (joint)", f"{c['pose_rms_after_um']['value']:.1f} um"],
        ["two-step calibration", f"{c['pose_rms_after_two_step_um']['value']:.0f} um"],
    ])


# --- Monte-Carlo studies ----------------------------------------------------------------------------------------
@functools.cache
def study(scenario: str, trials: int, factor: float | None = None) -> dict:
    """A Monte-Carlo study (seed 0, analytic, all cores): its summary. ``factor``: every stated
    sigma times this (benchmarks/datasheet_coverage.py's tables)."""
    from calibench.scenarios.montecarlo import run_study

    table_ = None
    if factor is not None:
        sys.path.insert(0, str(ROOT / "benchmarks"))
        from datasheet_coverage import STATED, scaled

        table_ = scaled(STATED[scenario], factor)
    out = scratch() / "montecarlo" / f"{scenario}-{trials}-{factor}"
    return run_study(scenario, trials, 0, "analytic", out, progress=False, table=table_)


def coverages(summary: dict) -> list[dict]:
    """The parameters that report a std."""
    return [p for p in summary["parameters"] if p["coverage_95"] is not None]


@block(seconds=230, ci=False, rel=0.01)
def datasheet_coverage():
    """benchmarks/datasheet_coverage.py's studies: 1000 arm and 200 Stewart trials with the
    datasheet right, 1.5x too large and 1.5x too small."""
    out = {}
    for scenario, n in (("arm-cmm", 1000), ("stewart", 200)):
        pooled, outside = [], []
        for factor in (1.0, 1.5, 1 / 1.5):
            ps = coverages(study(scenario, n, factor))
            pooled.append(sum(p["coverage_95"] for p in ps) / len(ps))
            outside.append(sum(not lo <= p["coverage_95"] <= hi for p in ps for lo, hi in [p["coverage_95_expected"]]))
        band = ps[0]["coverage_95_expected"]
        out[scenario] = (n, pooled, outside, len(ps), band)
    (na, pa, oa, ka, ba), (ns, pst, ost, ks, bs) = out["arm-cmm"], out["stewart"]
    same = all(span(x) == format(x[0], ".3f") for x in (pa, pst))
    why = (", the same in all three, since a common factor on every sigma changes the weights of nothing and the "
           "variance factor restores the std" if same else " over the three datasheets")
    return (f"`benchmarks/datasheet_coverage.py` runs {na} arm and {ns} Stewart trials with the datasheet's sigma "
            f"right, 1.5x too large and 1.5x too small: pooled coverage {span(pa, '.3f', ' to ')} (arm, band "
            f"{ba[0]:.3f}-{ba[1]:.3f}) and {span(pst, '.3f', ' to ')} (Stewart, band {bs[0]:.2f}-{bs[1]:.2f}){why}; "
            f"{span(oa, 'd', ' to ')} of {ka} and {span(ost, 'd', ' to ')} of {ks} parameters' own coverage outside "
            f"their binomial band.")


@block(seconds=250, ci=False, rel=0.01)
def montecarlo_studies():
    """calibench montecarlo arm-cmm --trials 1000, stewart --trials 1000, belt-stage --trials 200
    (seed 0, analytic)."""
    rows = []
    # the arm's parameters are those with an independent reference (the frames and the errors that
    # absorb others are judged by held-out positions, not by coverage)
    for scenario, n, what in (("arm-cmm", 1000, "parameters with a reference"), ("stewart", 1000, "leg parameters"),
                              ("belt-stage", 200, "parameters")):
        s = study(scenario, n)
        ps = coverages(s)
        cov = [p["coverage_95"] for p in ps]
        eff = [p["efficiency"] for p in s["parameters"] if p.get("efficiency") is not None]
        mean = lambda xs: sum(xs) / len(xs)
        label = f"{scenario}{', analytic' if scenario == 'belt-stage' else ''} ({len(s['parameters'])} {what})"
        rows.append([label, f"{s['trials']}", f"{span(cov)} (mean {mean(cov):.3f})",
                     f"{span(eff, '.2f')} (mean {mean(eff):.2f})" if eff else "(no bound computed)"])
    return table(["study", "trials", "coverage_95", "efficiency (CRLB var / MC var)"], rows)


# The physics each twin can carry, as a run's config switches it on (README, "Physics in the twins"):
# (scenario, arm, trials, what, config table, the check to show, its scale to um).
PHYSICS = (
    ("belt-stage", None, 20, "both belts elastic (EA 35 kN) against 4 N of carriage friction",
     {"truth": {"belt_x": {"ea_n": 35e3, "friction_n": 4.0}, "belt_y": {"ea_n": 35e3, "friction_n": 4.0}}},
     "check_rms_after_mm", 1000),
    ("stewart", None, 100, "every leg 0.03 um/N under MuJoCo's statics, 1000 N payload",
     {"truth": {"leg_compliance_um_per_n": [0.03] * 6, "payload_n": 1000.0}}, "pose_rms_after_um", 1),
    ("arm-cmm", "ur10", 200, "a UR10, joints 1-6 of 3e5, 2e5, 3e5, 6e4, 6e4, 6e4 N m/rad under MuJoCo's gravity",
     {"truth": {"stiffness_nm_per_rad": [3e5, 2e5, 3e5, 6e4, 6e4, 6e4]}}, None, 1),
)


@functools.cache
def physics_study(scenario: str, trials: int, physics: bool) -> dict:
    """A Monte-Carlo study (seed 0, analytic) of the rigid twin or of the one with PHYSICS on."""
    from calibench.scenarios.montecarlo import run_study

    arm, table_ = next((a, t) for s, a, n, _, t, *_ in PHYSICS if s == scenario)
    out = scratch() / "physics" / f"{scenario}-{trials}-{physics}"
    return run_study(scenario, trials, 0, "analytic", out, progress=False, table=table_ if physics else None, arm=arm)


@block(seconds=200, ci=False)
def physics_studies():
    """calibench montecarlo with each twin's physics off and on (PHYSICS): what a geometry-only
    calibration does on a machine that has it."""
    rows = []
    for scenario, _, n, what, _, check, scale in PHYSICS:
        cells = []
        for physics in (False, True):
            s = physics_study(scenario, n, physics)
            ps = coverages(s)
            cov = sum(p["coverage_95"] for p in ps) / len(ps)
            out = sum(not lo <= p["coverage_95"] <= hi for p in ps for lo, hi in [p["coverage_95_expected"]])
            worst = max(ps, key=lambda p: abs(p["bias"]) / p["mean_std"])
            c = next((c for c in s.get("checks", []) if c["name"] == check), None)
            cells.append((cov, out, len(ps), worst, c, {p["name"]: p["mean_std"] for p in ps}))
        (c0, o0, k, _, k0, s0), (c1, o1, _, w, k1, s1) = cells
        grow = sorted(s1[n_] / s0[n_] for n_ in s0)[len(s0) // 2]
        checked = "-" if k0 is None else f"{scale * k0['median']:.1f} -> {scale * k1['median']:.1f} um ({check})"
        rows.append([f"{scenario}: {what}", f"{n}", f"{c0:.3f} -> {c1:.3f}", f"{o0} -> {o1} of {k}",
                     f"{w['name']}: {abs(w['bias']) / w['mean_std']:.1f} std", f"x {grow:.1f}", checked])
    return table(["study (rigid twin -> with physics)", "trials", "pooled coverage_95",
                  "parameters outside their band", "worst bias", "reported std (median)", "median check"], rows)


@block(seconds=1, ci=True)
def coverage_bands():
    """scenarios.montecarlo.summarise's band for an honest 95 % coverage at 1000 and 200 trials."""
    from calibench.scenarios.montecarlo import summarise

    def band(n):  # the band summary.json writes beside every coverage, for n trials
        rows = [{"trial": i, "ok": True, "p.estimate": 0.0, "p.truth": 0.0, "p.std": 1.0, "p.unit": ""}
                for i in range(n)]
        return summarise("any", rows, 0.0)["parameters"][0]["coverage_95_expected"]

    b1, b2 = band(1000), band(200)
    return (f"With N trials an honest 95 % coverage itself scatters: its 95 % band is {b1[0]:.3f}-{b1[1]:.3f} at "
            f"1000 trials and {b2[0]:.2f}-{b2[1]:.2f} at 200, and `summary.json` gives that band "
            f"(`coverage_95_expected`) beside every coverage and a chi-square 95 % interval beside every efficiency, "
            f"so a reader can tell scatter from a dishonest std.")


# --- discover ------------------------------------------------------------------------------------------------------
@block(seconds=250, ci=False)
def discover_suite():
    """The concealed-effect suite (scenarios/discover_suite.py, as benchmarks/discover.py runs it)."""
    from calibench.scenarios.discover_suite import SUITE, run_case, score

    s = score([run_case(*case) for case in SUITE])
    what, value, limit = s["worst_param"]
    worst = (f"a compliance {value:.2f} std from the truth, limit {limit:g} std" if "std" in what
             else f"{what} {value:.2f} of its limit {limit:g}")
    return (f"{s['recordings']} recordings; detection {s['detection']:.0%}, false claims on nulls "
            f"{s['null_false_claim_rate']:.0%}, spurious claims beside real ones {s['spurious_claims']}, parameters "
            f"within limits {s['params_within_limit']:.0%} (worst: {worst}), cv after/before <= 0.5 in "
            f"{s['ratios_ok']:.0%} of {s['n_dominated']} dominated recordings (worst {s['worst_ratio']:.2f}).")


# One concealed recording per instrument (its kind and the suite's seed): discover's figure saved
# to docs/discover_<scenario>.png and its numbers in the README.
SHOWCASE = (("belt-stage", "combined", 1), ("vision-stage", "bump", 0), ("probe-scanner", "combined", 0),
            ("arm-cmm:ur10", "compliance", 0), ("stewart", "compliance", 0))


@block(seconds=45, ci=True, rel=0.02)
def discover_instruments():
    """calibench discover on one concealed recording of each instrument (sim/concealed.py): the
    effects found against the concealed ones, the held-out RMS and the repeatability."""
    import numpy as np

    from calibench.scenarios.discover import _figure
    from calibench.scenarios.discover_suite import concealed_discovery

    rows = []
    for scenario, kind, seed in SHOWCASE:
        man, out, fig = concealed_discovery(scenario, kind, seed)
        name = scenario.replace(":", "_")
        _figure(ROOT / "docs" / f"discover_{name}.png", out, fig)

        def label(e):
            where = e["params"].get("leg") or e["params"].get("joint")
            return f"`{e['name']}` ({e['axis']}{f' {where}' if where else ''})"

        concealed = ", ".join(label(e) for e in man["effects"]) or "-"
        found = ", ".join(label(e) for e in out["effects"] if e["name"] != "geometry") or "-"
        f = out["fit"]
        before = next((e["cv_rms_after"] for e in out["effects"] if e["name"] == "geometry"), f["cv_rms_nominal"])
        noise = out.get("noise_after_effects") or {}
        reps = [v["repeatability_mm"] for v in noise.values() if v["repeatability_mm"]]
        rep = f"{1000 * float(np.sqrt(np.mean(np.square(reps)))):.2f}" if reps else "-"
        rows.append([f"{scenario.replace('arm-cmm:ur10', 'arm-cmm (UR10)')}, {kind} "
                     f"([figure](docs/discover_{name}.png))", concealed, found,
                     f"{1000 * before:.2f} -> {1000 * f['cv_rms_final']:.2f}", rep])
    return table(["recording", "concealed", "found", "held-out RMS (um)", "repeatability after (um)"], rows)


NULLS = 30
FLOORS = (0.02, 0.03, 0.05, 0.10)
STAGE_FLOORS = (0.02, 0.05, 0.10)  # benchmarks/discover.py's; 3 % is the arm's floor only


@functools.cache
def null_claims() -> dict:
    """For each scenario and floor, the share of NULLS fresh null recordings (seeds 5000+, as
    benchmarks/discover.py draws them) on which discover claims any effect."""
    from calibench.scenarios.discover import discover_arm, discover_stage
    from calibench.sim.concealed import arm_recording, stage_recording

    out = {}
    for sc in ("belt-stage", "vision-stage", "arm-cmm", "arm-cmm:ur10"):
        arm = sc.partition(":")[2] or "arm-cmm"
        floors = FLOORS if sc.startswith("arm") else STAGE_FLOORS
        claims = {f: 0 for f in floors}
        for k in range(NULLS):
            rec = (arm_recording("null", 5000 + k, arm=arm) if sc.startswith("arm") else
                   stage_recording(sc, "null", 5000 + k))[0]
            for f in floors:
                d = (discover_arm(rec, 0, f, arm=arm) if sc.startswith("arm")
                     else discover_stage(sc, rec, 0, None, f))[0]
                claims[f] += any(e["name"] != "geometry" for e in d["effects"])
        out[sc] = {f: claims[f] / NULLS for f in floors}
    return out


@block(seconds=760, ci=False)
def discover_nulls():
    """discover on 30 fresh null recordings per scenario at several floors: the false-claim rate."""
    from calibench.estimators.discovery import FLOOR
    from calibench.scenarios.discover import ARM_FLOOR

    rates = null_claims()
    rows = [[sc.replace("arm-cmm:ur10", "arm-cmm, UR10"),
             *[f"{rates[sc][f]:.0%}" if f in rates[sc] else "-" for f in FLOORS]] for sc in rates]
    stages = [sc for sc in rates if not sc.startswith("arm")]
    arms = [sc for sc in rates if sc.startswith("arm")]
    low = [rates[sc][FLOORS[0]] for sc in stages]
    text = table([f"scenario ({NULLS} nulls each)", *[f"floor {f:.0%}" for f in FLOORS]], rows)
    text += (f"\n\nThe stages' floor is {FLOOR:.0%}: "
             f"{sum(rates[sc][FLOOR] for sc in stages) * NULLS:.0f} false claims in {len(stages) * NULLS} nulls, where "
             f"{FLOORS[0]:.0%} gives {span(low, '.0%')}; the arm's is {ARM_FLOOR:.0%}: "
             f"{sum(rates[sc][ARM_FLOOR] for sc in arms) * NULLS:.0f} in {len(arms) * NULLS} nulls of the seed's arm "
             f"and the UR10.")
    return text


def paper_recording():
    """The seed paper's measured belt-stage tables as a stage recording."""
    from calibench.scenarios.discover import paper_belt_recording

    need_data(DATA / "seed_belt_stage")
    return paper_belt_recording(DATA / "seed_belt_stage")


@functools.cache
def paper_discovery(holdout: str) -> dict:
    """discover belt-stage on the seed paper's measured tables, holding out whole rows or columns."""
    from calibench.scenarios.discover import discover_stage

    return discover_stage("belt-stage", paper_recording(), 0, holdout)[0]


@block(seconds=3, ci=True)
def paper_belt_discover():
    """discover belt-stage on the paper's measured belt stage (as benchmarks/discover.py runs it),
    holding out whole rows and whole columns."""
    rows, cols = paper_discovery("rows"), paper_discovery("columns")
    loc = rows["located"][0]
    where = re.match(r"largest at (\w) (\S+) mm \(mean (\S+) um\)", loc["where"])
    axis, at, mean = where.group(1), where.group(2), float(where.group(3))
    fr = rows["fit"]
    degree = {2: "quadratic", 3: "cubic", 4: "quartic", 5: "quintic", 6: "sextic"}
    terms = []
    for e in rows["effects"]:
        if e["name"] == "periodic":
            terms.append(f"a {e['params']['period_mm']:.0f} mm periodic term in {e['axis'].upper()} "
                         f"({e['params']['amplitude_mm']:.2f} mm)")
        else:  # polynomial terms name their powers: x4y0_mm is x^4
            n = max(sum(map(int, re.findall(r"\d+", k))) for k in e["params"])
            terms.append(f"a {degree.get(n, f'degree-{n}')} {e['axis'].upper()} {e['name']} term")
    fitted_axes = words(sorted({e["axis"].upper() for e in rows["effects"]}))
    best = max(((k, float(m.group(1))) for k, v in cols["not_accepted"].items()
                for m in [re.search(r"by (\S+) %", v)] if m), key=lambda t: t[1])
    others = [x for x in ("x", "y") if x != axis and not any(d["driver"] == x for d in rows["located"])]
    rec = paper_recording()
    distinct = {len(set(rec.x_cmd_mm)), len(set(rec.y_cmd_mm))}
    return "\n".join([
        f"- Residual after the paper's quadratic: {fr['rms_nominal'] * 1000:.0f} um RMS; held out, "
        f"{fr['cv_rms_nominal'] * 1000:.0f} um (whole rows) and {cols['fit']['cv_rms_nominal'] * 1000:.0f} um "
        f"(whole columns).",
        f"- Where it lives: the **{axis.upper()} axis's error against its own position** (score {loc['score']:.2f}, "
        f"p {loc['p_value']:.3f}), most at {axis} = {at} mm, where the quadratic leaves a mean of {mean:.0f} um."
        + "".join(f" The {o.upper()} axis's residual has no driver that stands out." for o in others),
        f"- What a better model gains: holding out whole rows, {words(terms)} pass the floor "
        f"({fr['cv_rms_nominal'] * 1000:.0f} -> {fr['cv_rms_final'] * 1000:.0f} um, "
        f"{(fr['cv_rms_final'] / fr['cv_rms_nominal'] - 1) * 100:.0f} %); holding out whole columns, "
        + ("nothing does" if not cols["effects"] else words(e["name"] for e in cols["effects"]) + " do")
        + f" (the best, the {best[0].split(':')[1].upper()} axis's {best[0].split(':')[0]} term, gains {best[1]:.0f} "
        f"%). With {span(distinct, 'd')} distinct positions per axis the {fitted_axes} terms interpolate the columns "
        f"they were fitted on and do not carry to an unseen column: not confirmed. The finding is the "
        f"{axis.upper()} axis's structure at {at} mm, which no smooth or periodic term predicts for an unseen "
        f"position: it needs repeated passes (to tell a local defect from noise) and finer stations there.",
    ])


# --- real data ------------------------------------------------------------------------------------------------------
def _camera(folder: str, pattern: str, *flags) -> dict:
    out = scratch() / "camera" / folder
    images = sorted((DATA / folder).glob(pattern))
    need_data(DATA / folder)
    calibench("camera", *images, *flags, "--out", out)
    return json.loads((out / "intrinsics.json").read_text())


@block(seconds=6, ci=True)
def real_data():
    """calibench camera on OpenCV's and BoofCV's photos, calibench fit belt-stage on the paper's
    tables (examples/belt_stage_paper.csv)."""
    import cv2
    import yaml

    cv = _camera("opencv_left", "left*.jpg", "--cols", 9, "--rows", 6, "--square-mm", 25, "--fix-aspect")
    ref = cv2.FileStorage(str(DATA / "opencv_left" / "left_intrinsics.yml"), cv2.FILE_STORAGE_READ)
    K0, rms0, n_cv = ref.getNode("camera_matrix").mat(), ref.getNode("avg_reprojection_error").real(), len(cv["used"])
    K = cv["K"]
    bf = _camera("boofcv_chess", "*.jpg", "--cols", 4, "--rows", 6, "--square-mm", 30, "--radial", 2,
                 "--no-tangential")
    pin = yaml.safe_load((DATA / "boofcv_chess" / "intrinsic.yaml").read_text())["pinhole"]
    Kb = bf["K"]
    out = scratch() / "fit" / "belt-stage"
    calibench("fit", "belt-stage", ROOT / "examples" / "belt_stage_paper.csv", "--out", out)
    ax = json.loads((out / "fit.json").read_text())["axes"]
    x, y = ax["x"], ax["y"]
    return "\n".join([
        f"- `calibench camera` on OpenCV's {n_cv} `left*.jpg` (9x6, 25 mm, `--fix-aspect`): fx {K[0][0]:.1f} against "
        f"the shipped {K0[0, 0]:.1f} ({(K[0][0] / K0[0, 0] - 1) * 100:+.2f} %), principal point "
        f"{math.hypot(K[0][2] - K0[0, 2], K[1][2] - K0[1, 2]):.1f} px away, RMS {cv['rms_px']:.2f} px "
        f"(reference: {rms0:.2f} px).",
        f"- On BoofCV's chessboard set with BoofCV's model (`--radial 2 --no-tangential`): fx {Kb[0][0]:.1f} / "
        f"fy {Kb[1][1]:.1f} against {pin['fx']:.1f} / {pin['fy']:.1f} ({(Kb[0][0] / pin['fx'] - 1) * 100:+.1f} %), "
        f"principal point {math.hypot(Kb[0][2] - pin['cx'], Kb[1][2] - pin['cy']):.1f} px away.",
        f"- `calibench fit belt-stage` on the paper's measured tables reproduces its Table 3 to every printed digit "
        f"(SSE {x['sse']:.2f} / {y['sse']:.2f} mm^2, R^2 {x['r2']:.4f} / {y['r2']:.4f}, RMSE {x['rmse']:.4f} / "
        f"{y['rmse']:.4f} mm).",
        "- `calibench fit vision-stage` fits the cubic of Eq. 5-9 (model `cubic`, coefficients a0..a9).",
    ])


@block(seconds=3, ci=True)
def python_example():
    """The README's Python example's identification on ur10_D (calibench.estimators, no MuJoCo)."""
    from calibench.estimators.arm_identification import PointProblem, identify_identifiable
    from calibench.recordings import load_arm_csv
    from calibench.scenarios.arms import chain_of, load_arm

    rec = load_arm_csv(series("D")[0], n_joints=6)
    ident = identify_identifiable(PointProblem(chain_of(load_arm("ur10")), rec.q_rad, rec.xyz_mm))
    return f"On ur10_D its second line prints `da2 = {ident.estimate['da2']:.3f} +- {ident.std['da2']:.3f} mm`."


# --- the README ---------------------------------------------------------------------------------------------------
OPEN = re.compile(r"^(?P<indent>[ \t]*)<!-- figures:(?P<name>[\w.-]+) -->[ \t]*$")


def spans(text: str) -> dict[str, tuple[int, int, str]]:
    """Each block of the README: (first content line, closing marker's line, indentation), lines
    counted from 0."""
    lines = text.split("\n")
    out = {}
    for i, line in enumerate(lines):
        m = OPEN.match(line)
        if not m:
            continue
        name = m["name"]
        close = next((j for j in range(i + 1, len(lines)) if lines[j].strip() == f"<!-- /figures:{name} -->"), None)
        if close is None:
            raise ValueError(f"README.md: <!-- figures:{name} --> has no closing <!-- /figures:{name} -->")
        if name in out:
            raise ValueError(f"README.md: block {name} appears twice")
        out[name] = (i + 1, close, m["indent"])
    return out


def current(text: str, name: str) -> str:
    """The README's text of a block, without its indentation and surrounding blank lines."""
    a, b, indent = spans(text)[name]
    return "\n".join(line.removeprefix(indent) for line in text.split("\n")[a:b]).strip("\n")


WIDTH = 100  # the README's line length


def layout(text: str, indent: str = "") -> list[str]:
    """A block's lines as the README holds them: prose and list items wrapped to WIDTH (a list
    item's lines under its text), table rows as they are, every line indented like the markers."""
    out = []
    for line in text.strip("\n").split("\n"):
        if not line.strip() or line.lstrip().startswith("|"):
            out.append(indent + line if line.strip() else "")
            continue
        hang = "  " if line.startswith("- ") else ""
        out += textwrap.wrap(line, WIDTH - len(indent), initial_indent=indent, subsequent_indent=indent + hang,
                             break_long_words=False, break_on_hyphens=False)
    return out


def replace(text: str, generated: dict[str, str]) -> str:
    """The README with the given blocks' texts replaced. A block at the margin gets a blank line
    on either side (a table or paragraph of its own); an indented one (inside a list item) none,
    so that it reads on with the item's text."""
    lines = text.split("\n")
    for name, (a, b, indent) in sorted(spans(text).items(), key=lambda kv: -kv[1][0]):
        if name not in generated:
            continue
        body = layout(generated[name], indent)
        lines[a:b] = ([""] + body + [""]) if not indent else body
    return "\n".join(lines)


NUMBER = re.compile(r"(?<![\w.])-?\d{1,3}(?:,\d{3})+(?![\d.])|(?<![\w.])-?\d+(?:\.\d+)?(?:[eE][-+]?\d+)?")


def numbers(text: str) -> list[tuple[float, str]]:
    """The numbers of a text in order, with how each is printed. A minus sign right after a
    letter or digit is a dash ('1.0-1.8', 'joint-6'), not a sign; '2,773' is one number."""
    out = []
    for m in NUMBER.finditer(text):
        tok = m.group(0)
        if tok.startswith("-") and m.start() > 0 and (text[m.start() - 1].isalnum() or text[m.start() - 1] in ".)"):
            tok = tok[1:]
        out.append((float(tok.replace(",", "")), tok))
    return out


def last_digit_unit(tok: str) -> float:
    """One unit of a printed number's last digit: '0.0083' -> 1e-4, '2519' -> 1, '3e-10' -> 1e-10."""
    mant, _, exp = tok.lower().partition("e")
    decimals = len(mant.partition(".")[2])
    return 10.0 ** (-decimals + (int(exp) if exp else 0))


def disagreements(b: Block, readme: str, generated: str) -> list[str]:
    """Where the README's numbers and the generated ones differ beyond the block's tolerance."""
    old, new = numbers(readme), numbers(generated)
    if len(old) != len(new):
        return [f"{b.name}: {len(old)} numbers in README.md, {len(new)} generated; the generated text:\n{generated}"]
    out = []
    for (x, tx), (y, ty) in zip(old, new):
        tol = max(b.rel * abs(x), b.last_digit * last_digit_unit(tx))
        # the printed digits must agree unless the block allows more (a relative band, a digit)
        if tx != ty and abs(x - y) > tol:
            out.append(f"{b.name}: README says {tx}, the code gives {ty}")
    return out


def check(names: list[str], readme: str) -> int:
    """Regenerate the named blocks and compare with the README; the number of disagreements."""
    bad = 0
    for name in names:
        b = BLOCKS[name]
        t = time.perf_counter()
        try:
            generated = b.make()
        except Exception as e:  # noqa: BLE001 - one block's failure is reported, the others still checked
            print(f"{name}: could not be generated: {type(e).__name__}: {e}", flush=True)
            bad += 1
            continue
        found = disagreements(b, current(readme, name), generated)
        for line in found:
            print(line)
        if not found and " ".join(generated.split()) != " ".join(current(readme, name).split()):
            print(f"{name}: the numbers agree but the words differ from the generator's (python docs/figures.py "
                  f"{name} rewrites it)")
        print(f"{name}: {'ok' if not found else 'DIFFERS'} ({time.perf_counter() - t:.0f} s)", flush=True)
        bad += len(found)
    return bad


def main(argv: list[str] | None = None) -> int:
    """The command line (see the module's docstring); returns the exit status."""
    ap = argparse.ArgumentParser(description="Regenerate (or --check) the README's generated blocks.")
    ap.add_argument("names", nargs="*", metavar="NAME", help="blocks to regenerate (default: all)")
    ap.add_argument("--check", action="store_true", help="compare with README.md instead of rewriting it")
    ap.add_argument("--list", action="store_true", help="list the blocks and their run times")
    args = ap.parse_args(argv)
    if args.list:
        for b in BLOCKS.values():
            print(f"{b.name:24s} {b.seconds:6.0f} s  {'test' if b.ci else 'make '}  {b.what}")
        return 0
    readme = README.read_text()
    in_readme = spans(readme)
    unknown = [n for n in args.names if n not in BLOCKS]
    if unknown:
        print(f"unknown block(s): {', '.join(unknown)} (python docs/figures.py --list)", file=sys.stderr)
        return 2
    names = args.names or list(BLOCKS)
    orphans = [n for n in in_readme if n not in BLOCKS]
    missing = [n for n in names if n not in in_readme]
    if orphans or missing:
        for n in orphans:
            print(f"README.md has a block {n} that docs/figures.py does not generate")
        for n in missing:
            print(f"README.md has no markers for block {n}")
        return 1
    if args.check:
        bad = check(names, readme)
        print(f"{len(names)} blocks checked: {'all agree' if not bad else f'{bad} numbers differ'}")
        return 1 if bad else 0
    for name in names:
        t = time.perf_counter()
        text = BLOCKS[name].make()
        # written at once (an interrupted run keeps what it made), into the README as it is now
        README.write_text(replace(README.read_text(), {name: text}))
        print(f"{name}: rewritten ({time.perf_counter() - t:.0f} s)", flush=True)
    print(f"README.md: {len(names)} blocks rewritten")
    return 0


if __name__ == "__main__":
    sys.exit(main())
