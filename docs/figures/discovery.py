"""The discovery's blocks: the concealed-effect suite, one recording per instrument, the null
calibration of the floors, the seed paper's measured belt stage, the discovery's own words, and
the twin it writes, replayed."""

from __future__ import annotations

import functools
import json
import re

from .engine import ROOT, block
from .fmt import span, table, words
from .runner import DATA, SEED, calibench, need_data, scratch

RATIO_LIMIT = 0.5  # scenarios.discover.suite.score's bound on held-out RMS after / before

# One concealed recording per instrument (its kind and the suite's seed): discover's figure saved
# to docs/discover_<scenario>.png and its numbers in the README.
SHOWCASE = (
    ("belt-stage", "combined", 1),
    ("vision-stage", "bump", 0),
    ("probe-scanner", "combined", 0),
    ("arm-cmm:ur10", "compliance", 0),
    ("stewart", "compliance", 0),
)

NULLS = 30  # fresh null recordings per scenario
FLOORS = (0.02, 0.03, 0.05, 0.10)
STAGE_FLOORS = (0.02, 0.05, 0.10)  # benchmarks/discover.py's; 3 % is the arm's floor only

# The twin written by discover --twin and replayed by discover --config, one recording per
# instrument (tests/scenarios/test_discover_twin.py's and test_discover_instruments.py's).
TWIN_CASES = (
    ("belt stage", "belt-stage", "elastic", 2),
    ("vision stage", "vision-stage", "mixed", 4),
    ("Stewart", "stewart", "compliance", 5),
    ("arm", "arm-cmm", "compliance", 1017),
    ("scanner", "probe-scanner", "combined", 1017),
)


@block(seconds=215, ci=False)
def discover_suite():
    """The concealed-effect suite (scenarios/discover_suite.py, as benchmarks/discover.py runs
    it)."""
    from calibench.scenarios.discover.suite import run_case, score, suite_cases

    return suite_words(score([run_case(*case) for case in suite_cases()]))


def suite_words(s: dict) -> str:
    """The suite's scores (``scenarios.discover.suite.score``) as the block says them:
    tests/scenarios/test_discover_suite.py checks the README against its own run with it."""
    what, value, limit = s["worst_param"]
    worst = (
        f"a compliance {value:.2f} std from the truth, limit {limit:g} std"
        if "std" in what
        else f"{what} {value:.2f} of its limit {limit:g}"
    )
    return (
        f"{s['recordings']} recordings; detection {s['detection']:.0%}, false claims on nulls "
        f"{s['null_false_claim_rate']:.0%}, spurious claims beside real ones "
        f"{s['spurious_claims']}, parameters within limits {s['params_within_limit']:.0%} "
        f"(worst: {worst}), cv after/before <= {RATIO_LIMIT:g} in {s['ratios_ok']:.0%} of "
        f"{s['n_dominated']} dominated recordings (worst {s['worst_ratio']:.2f}; on the "
        "selection's own folds: in-sample for the structure it chose)."
    )


@block(seconds=45, ci=True, rel=0.02)
def discover_instruments():
    """calibench discover on one concealed recording of each instrument (sim/concealed.py): the
    effects found against the concealed ones, the held-out RMS and the repeatability."""
    import numpy as np

    from calibench.scenarios.discover.figure import write_figure
    from calibench.scenarios.discover.suite import concealed_discovery

    def label(e):
        where = e["params"].get("leg") or e["params"].get("joint")
        return f"`{e['name']}` ({e['axis']}{f' {where}' if where else ''})"

    rows = []
    for scenario, kind, seed in SHOWCASE:
        man, out, fig = concealed_discovery(scenario, kind, seed)
        name = scenario.replace(":", "_")
        write_figure(ROOT / "docs" / f"discover_{name}.png", out, fig)
        concealed = ", ".join(label(e) for e in man["effects"]) or "-"
        found = ", ".join(label(e) for e in out["effects"] if e["name"] != "geometry") or "-"
        f = out["fit"]
        before = next(
            (e["cv_rms_after"] for e in out["effects"] if e["name"] == "geometry"),
            f["cv_rms_nominal"],
        )
        noise = out.get("noise_after_effects") or {}
        reps = [v["repeatability_mm"] for v in noise.values() if v["repeatability_mm"]]
        rep = f"{1000 * float(np.sqrt(np.mean(np.square(reps)))):.2f}" if reps else "-"
        rows.append(
            [
                f"{scenario.replace('arm-cmm:ur10', 'arm-cmm (UR10)')}, {kind} "
                f"([figure](discover_{name}.png))",  # beside its page, docs/discover.md
                concealed,
                found,
                f"{1000 * before:.2f} -> {1000 * f['cv_rms_final']:.2f}",
                rep,
            ]
        )
    return table(
        ["recording", "concealed", "found", "held-out RMS (um)", "repeatability after (um)"], rows
    )


@functools.cache
def null_claims() -> dict:
    """For each scenario and floor, the share of NULLS fresh null recordings (seeds 5000+, as
    benchmarks/discover.py draws them) on which discover claims any effect; the recordings
    shared among the cores (scenarios.discover.nulls)."""
    from calibench.scenarios.discover.nulls import null_claim_rates

    scenarios = ("belt-stage", "vision-stage", "arm-cmm", "arm-cmm:ur10")
    return null_claim_rates(
        {sc: (FLOORS if sc.startswith("arm") else STAGE_FLOORS) for sc in scenarios}, NULLS
    )


@block(seconds=400, ci=False)
def discover_nulls():
    """discover on 30 fresh null recordings per scenario at several floors: the false-claim rate."""
    from calibench.estimators.discovery.select import FLOOR
    from calibench.scenarios.arm_cmm.discovery import ARM_FLOOR

    rates = null_claims()
    rows = [
        [
            sc.replace("arm-cmm:ur10", "arm-cmm, UR10"),
            *[f"{rates[sc][f]:.0%}" if f in rates[sc] else "-" for f in FLOORS],
        ]
        for sc in rates
    ]
    stages = [sc for sc in rates if not sc.startswith("arm")]
    arms = [sc for sc in rates if sc.startswith("arm")]
    low = [rates[sc][FLOORS[0]] for sc in stages]
    text = table([f"scenario ({NULLS} nulls each)", *[f"floor {f:.0%}" for f in FLOORS]], rows)
    text += (
        f"\n\nThe stages' floor is {FLOOR:.0%}: "
        f"{sum(rates[sc][FLOOR] for sc in stages) * NULLS:.0f} false claims in "
        f"{len(stages) * NULLS} nulls, where {FLOORS[0]:.0%} gives {span(low, '.0%')}; the arm's "
        f"is {ARM_FLOOR:.0%}: {sum(rates[sc][ARM_FLOOR] for sc in arms) * NULLS:.0f} in "
        f"{len(arms) * NULLS} nulls of the seed's arm and the UR10."
    )
    return text


def paper_recording():
    """The seed paper's measured belt-stage tables as a stage recording."""
    from calibench.scenarios.stages.discovery import paper_belt_recording

    need_data(DATA / "seed_belt_stage")
    return paper_belt_recording(DATA / "seed_belt_stage")


@functools.cache
def paper_discovery(holdout: str) -> dict:
    """discover belt-stage on the seed paper's measured tables, holding out whole rows or
    columns."""
    from calibench.scenarios.stages.discovery import discover_stage

    return discover_stage("belt-stage", paper_recording(), SEED, holdout)[0]


DEGREE = {2: "quadratic", 3: "cubic", 4: "quartic", 5: "quintic", 6: "sextic"}


def term_words(e: dict) -> str:
    """One accepted effect of a stage's discovery as the paper-belt-discover block says it."""
    if e["name"] == "periodic":
        return (
            f"a {e['params']['period_mm']:.0f} mm periodic term in {e['axis'].upper()} "
            f"({e['params']['amplitude_mm']:.2f} mm)"
        )
    # polynomial terms name their powers: x4y0_mm is x^4
    n = max(sum(map(int, re.findall(r"\d+", k))) for k in e["params"])
    return f"a {DEGREE.get(n, f'degree-{n}')} {e['axis'].upper()} {e['name']} term"


@block(seconds=3, ci=True)
def paper_belt_discover():
    """discover belt-stage on the paper's measured belt stage (as benchmarks/discover.py runs it),
    holding out whole rows and whole columns."""
    rows, cols = paper_discovery("rows"), paper_discovery("columns")
    loc = rows["located"][0]
    where = re.match(r"largest at (\w) (\S+) mm \(mean (\S+) um\)", loc["where"])
    axis, at, mean = where.group(1), where.group(2), float(where.group(3))
    fr = rows["fit"]
    terms = [term_words(e) for e in rows["effects"]]
    fitted_axes = words(sorted({e["axis"].upper() for e in rows["effects"]}))
    best = max(
        (
            (k, float(m.group(1)))
            for k, v in cols["not_accepted"].items()
            for m in [re.search(r"by (\S+) %", v)]
            if m
        ),
        key=lambda t: t[1],
    )
    others = [
        x for x in ("x", "y") if x != axis and not any(d["driver"] == x for d in rows["located"])
    ]
    rec = paper_recording()
    distinct = {len(set(rec.x_cmd_mm)), len(set(rec.y_cmd_mm))}
    um = {k: fr[k] * 1000 for k in ("rms_nominal", "cv_rms_nominal", "cv_rms_final")}
    gained = (fr["cv_rms_final"] / fr["cv_rms_nominal"] - 1) * 100
    on_columns = (
        "nothing does" if not cols["effects"] else words(e["name"] for e in cols["effects"]) + " do"
    )
    best_term, best_axis = best[0].split(":")[0], best[0].split(":")[1].upper()
    return "\n".join(
        [
            f"- Residual after the paper's quadratic: {um['rms_nominal']:.0f} um RMS; held out, "
            f"{um['cv_rms_nominal']:.0f} um (whole rows) and "
            f"{cols['fit']['cv_rms_nominal'] * 1000:.0f} um (whole columns).",
            f"- Where it lives: the **{axis.upper()} axis's error against its own position** "
            f"(score {loc['score']:.2f}, p {loc['p_value']:.3f}), most at {axis} = {at} mm, where "
            f"the quadratic leaves a mean of {mean:.0f} um."
            + "".join(
                f" The {o.upper()} axis's residual has no driver that stands out." for o in others
            ),
            f"- What a better model gains: holding out whole rows, {words(terms)} pass the floor "
            f"({um['cv_rms_nominal']:.0f} -> {um['cv_rms_final']:.0f} um, {gained:.0f} %); "
            f"holding out whole columns, {on_columns} (the best, the {best_axis} axis's "
            f"{best_term} term, gains {best[1]:.0f} %). With {span(distinct, 'd')} distinct "
            f"positions per axis the {fitted_axes} terms interpolate the columns they were fitted "
            f"on and do not carry to an unseen column: not confirmed. The finding is the "
            f"{axis.upper()} axis's structure at {at} mm, which no smooth or periodic term "
            f"predicts for an unseen position: it needs repeated passes (to tell a local defect "
            f"from noise) and finer stations there.",
        ]
    )


# The discovery's own words, quoted in the README from named concealed recordings.
@block(seconds=20, ci=True)
def stewart_located():
    """What discover stewart's `located` says on the suite's lost-motion and thermal recordings
    of the platform (seed 0 of each)."""
    from calibench.scenarios.discover.suite import concealed_discovery

    said = [
        concealed_discovery("stewart", kind, 0)[1]["located"][0]["where"]
        for kind in ("backlash", "thermal")
    ]
    return ", ".join(f'"{s}"' for s in said)


@block(seconds=10, ci=True)
def growing_reversal():
    """What discover belt-stage says of the belt's growing lost motion (the suite's elastic
    recording, seed 2, as tests/scenarios/test_discover_twin.py runs it)."""
    from calibench.scenarios.stages.discovery import discover_stage
    from calibench.sim.concealed import stage_recording

    d, _ = discover_stage("belt-stage", stage_recording("belt-stage", "elastic", 2)[0], 0)
    (e,) = [e for e in d["effects"] if e.get("grows_along_travel")]
    return f'"{e["physics"].split(" (a belt")[0]} ..."'


@block(seconds=60, ci=True)
def twin_replay():
    """discover --twin, then discover --config with that twin, on each of TWIN_CASES: the
    held-out RMS the discovery reached, and the replayed twin's."""
    from calibench.sim import concealed

    make = {
        "belt-stage": concealed.stage_recording,
        "vision-stage": concealed.stage_recording,
        "stewart": concealed.stewart_recording,
        "arm-cmm": concealed.arm_recording,
        "probe-scanner": concealed.scanner_recording,
    }
    parts = []
    for label, scenario, kind, seed in TWIN_CASES:
        rec, manifest = (
            make[scenario](scenario, kind, seed)
            if scenario.endswith("stage")
            else make[scenario](kind, seed)
        )
        out = scratch() / "twin" / scenario
        path = concealed.write_blinded(out, "rec", rec, manifest)
        calibench("discover", scenario, path, "--twin", out / "twin.toml", "--out", out / "found")
        calibench(
            "discover", scenario, path, "--config", out / "twin.toml", "--out", out / "replayed"
        )
        found = json.loads((out / "found" / "discovery.json").read_text())["fit"]["cv_rms_final"]
        replayed = json.loads((out / "replayed" / "discovery.json").read_text())["fit"]
        parts.append(f"{label} {1000 * found:.2f} -> {1000 * replayed['cv_rms_nominal']:.2f} um")
    return "Measured: " + ", ".join(parts) + "."
