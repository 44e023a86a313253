"""The real UR10's fits: the rows left out, trained on C and tested on the others, the coverage
check's words, and trained on all four series with the effects found or given."""

from __future__ import annotations

import functools
import json
import re

from .engine import ROOT, block
from .fmt import bold_least, percent, rows_words, table, words
from .runner import HOLDOUT, UR10, calibench, judged, scratch, series, ur10_discovery_c, ur10_fit

ALL = ("ur10_C.csv", "ur10_B.csv", "ur10_A.csv", "ur10_D.csv")
GEAR = "docs/ur10_gear_harmonics.json"
GEAR_Q2 = "docs/ur10_gear_harmonics_q2_table.json"  # GEAR and the table over q2 of discovery on C
H17 = "docs/ur10_harmonic17.json"
SHOULDER = 2  # the UR10's joint that gravity loads most, whose torque the coverage check reads

# not a calibench run: the issue's own mean errors (mm) of a rigid registration alone, trained on
# C, on B (a range), A and D
ISSUE_RIGID_MM = {"ur10_B.csv": (1.0, 1.8), "ur10_A.csv": 0.75, "ur10_D.csv": 0.93}


@block(seconds=10, ci=True)
def ur10_left_out():
    """calibench fit arm-cmm ur10_C.csv --test ur10_B.csv ... --model physics: the rows left out."""
    parts = []
    for name, rows in ur10_fit("C", model="physics")["flagged"].items():
        who = name.removeprefix("ur10_").removesuffix(".csv")
        kinds = {
            "beyond the fit's scatter": [
                r["row"] for r in rows if r["why"].startswith("its residual")
            ],
            "stale": [r["row"] for r in rows if r["why"].startswith("stale")],
            "the farther of a repeat that disagrees": [
                r["row"] for r in rows if r["why"].startswith("the same posture")
            ],
        }
        parts.append(f"{who}'s " + words([f"{rows_words(v)} ({k})" for k, v in kinds.items() if v]))
    return f"Left out by the physics fit on C below: {'; '.join(parts)}."


@block(seconds=15, ci=True)
def ur10_trained_on_c():
    """calibench fit arm-cmm ur10_C.csv --test B --test-new-frame A --test-new-frame D, --model
    geometry and physics."""
    geo, phys = ur10_fit("C", model="geometry"), ur10_fit("C", model="physics")
    joints = [
        n["name"].removeprefix("compliance")
        for n in phys["parameters"]
        if n["name"].startswith("compliance")
    ]
    # a compliance held at its bound (fitted below zero) is said beside the ones kept
    held = [
        d["name"].removeprefix("compliance")
        for d in phys["dropped"]
        if d["name"].startswith("compliance") and ("below zero" in d["why"] or "bound" in d["why"])
    ]
    held_said = f"; joint {words(held)}'s fitted below zero, held at zero" if held else ""
    cols = ["ur10_B.csv", "ur10_A.csv", "ur10_D.csv"]
    g = [geo["test"][c]["mean_mm"] for c in cols]
    p = [phys["test"][c]["mean_mm"] for c in cols]
    best = [bold_least([a, b], ".3f") for a, b in zip(g, p)]
    (lo, hi), a, d = (ISSUE_RIGID_MM[c] for c in cols)
    return table(
        ["trained on C", "B (same frame)", "A (new frame)", "D (new frame)"],
        [
            [
                "rigid registration alone (the issue's figures)",
                f"{lo:.1f}-{hi:.1f}",
                f"{a:.2f}",
                f"{d:.2f}",
            ],
            ["`--model geometry`", *[b[0] for b in best]],
            [
                f"`--model physics` (joint{'s' if len(joints) > 1 else ''} {words(joints)} "
                f"compliant under the twin's gravity{held_said})",
                *[b[1] for b in best],
            ],
        ],
    )


@block(seconds=15, ci=True)
def ur10_coverage():
    """calibench fit arm-cmm ur10_C.csv ..., --model geometry and physics: the fits on C itself,
    and the coverage check's words."""
    geo, phys = ur10_fit("C", model="geometry"), ur10_fit("C", model="physics")
    warn = phys["coverage"]["warnings"]
    one_way = next(w for w in warn if w.startswith(f"joint {SHOULDER}'s gravity torque"))
    share = re.search(r"(\d+) %", one_way).group(1)
    other = next(w for w in warn if w.startswith("ur10_D.csv") and f"load joint {SHOULDER}" in w)
    return (
        f"The geometry fits C as well as physics does ({geo['fit']['mean_mm']:.3f} against "
        f"{phys['fit']['mean_mm']:.3f} mm on C itself), but C's random poses hold the shoulder's "
        f'gravity torque one way ({share} % of them): the coverage check says so ("{other}"), and '
        f"only the compliance carries the fit to B, A and D."
    )


def table_joints(path: str) -> str:
    """The joints an effects file has a table over, as their angles: 'q2'."""
    spec = json.loads((ROOT / path).read_text())
    return words([f"q{e['params']['joint']}" for e in spec["effects"] if e["name"] == "nonsmooth"])


def effects_words(d: dict) -> str:
    """A discovery's joint-angle effects in words: 'gear harmonics of joints 1-3, a table over
    q2'."""

    def joints(name):
        js = sorted(e["params"]["joint"] for e in d["effects"] if e["name"] == name)
        if len(js) > 2 and js == list(range(js[0], js[-1] + 1)):
            return f"joints {js[0]}-{js[-1]}"
        return ("joint " if len(js) == 1 else "joints ") + words(map(str, js)) if js else ""

    out = [
        f"{what} of {joints(name)}"
        for name, what in (
            ("transmission", "gear harmonics"),
            ("encoder_eccentricity", "eccentricity"),
        )
        if joints(name)
    ]
    tables = sorted(e["params"]["joint"] for e in d["effects"] if e["name"] == "nonsmooth")
    return ", ".join(out + [f"a table over q{j}" for j in tables])


def terms_words(terms: list[str]) -> str:
    """fit.json's effect terms (``angle_transmission2``, ``angle_table2``...) in words, as
    :func:`effects_words` says a discovery's."""
    kinds = {
        "transmission": "transmission",
        "table": "nonsmooth",
        "eccentricity": "encoder_eccentricity",
    }
    matches = [m for m in (re.fullmatch(r"angle_([a-z]+)(\d+)(_rec\d+)?", t) for t in terms) if m]
    found = sorted({(m.group(1), int(m.group(2))) for m in matches})
    said = effects_words(
        {"effects": [{"name": kinds[k], "params": {"joint": j}} for k, j in found if k in kinds]}
    )
    per = sorted({int(m.group(2)) for m in matches if m.group(3)})
    return said + (
        f" (a phase per session on joint{'s' if len(per) > 1 else ''} {', '.join(map(str, per))})"
        if per
        else ""
    )


def gear_q2_is_current() -> None:
    """GEAR_Q2 holds GEAR's harmonics and the table edges of today's discovery on C: a discovery
    that moved its edges makes the file stale, and its figures with it."""
    import numpy as np

    spec = json.loads((ROOT / GEAR_Q2).read_text())
    gear = json.loads((ROOT / GEAR).read_text())["effects"]
    tables = [e["params"] for e in spec["effects"] if e["name"] == "nonsmooth"]
    found = [e["params"] for e in ur10_discovery_c()["effects"] if e["name"] == "nonsmooth"]

    def same_table(t, f):
        a, b = t.get("edges_deg", []), f.get("edges_deg", [])
        return (
            t.get("joint") == f.get("joint")
            and len(a) == len(b)
            and np.allclose(a, b, rtol=0, atol=1e-6)
        )

    same = (
        spec["effects"][: len(gear)] == gear
        and len(tables) == len(found)
        and all(same_table(t, f) for t, f in zip(tables, found))
    )
    if not same:
        raise SystemExit(
            f"{GEAR_Q2} is not GEAR's harmonics and the discovery on C's table: rewrite its "
            "effects from both"
        )


@block(seconds=850, ci=False)
def ur10_all_four():
    """calibench fit arm-cmm on all four series, --holdout 0.3: physics, with the discovery on C's
    effects (calibench discover arm-cmm ur10_C.csv), with fit's own discovery on the training rows
    (--effects discover), with per-session gear harmonics, and with those and the discovery's table
    over q2."""
    gear_q2_is_current()
    fits = [
        ur10_fit("all"),
        ur10_fit("all", "discovery-C"),
        ur10_fit("all", "discover"),
        ur10_fit("all", GEAR),
        ur10_fit("all", GEAR_Q2),
    ]
    scores = [judged(f) for f in fits]
    cells: list[list[str]] = [[] for _ in fits]
    for c in ALL:
        # the least of each series is bold among the held-out scores only: an in-sample one is
        # labelled, never a result
        held = [(i, s[c]) for i, (s, inside) in enumerate(scores) if c not in inside]
        a = dict(zip([i for i, _ in held], bold_least([x["mean_mm"] for _, x in held], ".3f")))
        b = dict(
            zip([i for i, _ in held], bold_least([round(x["max_mm"], 2) for _, x in held], ".2f"))
        )
        for i, (s, inside) in enumerate(scores):
            if c in inside:
                cells[i].append(f"({s[c]['mean_mm']:.3f} / {s[c]['max_mm']:.2f} in-sample)")
                continue
            both = a[i].startswith("**") and b[i].startswith("**")
            cells[i].append(
                f"**{a[i].strip('*')} / {b[i].strip('*')}**" if both else f"{a[i]} / {b[i]}"
            )
    found_in_training = terms_words(ur10_fit("all", "discover")["effects_from"]["terms"])
    return table(
        [
            f"trained on all four, {percent(HOLDOUT)} of each held out (random rows of the "
            "sessions trained on: interpolation; mean / max, mm)",
            *[c.removeprefix("ur10_").removesuffix(".csv") for c in ALL],
        ],
        [
            ["`--model physics`", *cells[0]],
            [
                f"with the effects discovery found on C ({effects_words(ur10_discovery_c())})",
                *cells[1],
            ],
            [
                f"with the effects discovery finds on the training rows alone (`--effects "
                f"discover`: {found_in_training})",
                *cells[2],
            ],
            [f"with gear harmonics whose phase each session sets (`--effects {GEAR}`)", *cells[3]],
            [
                f"with those gear harmonics and the table over {table_joints(GEAR_Q2)} of the "
                f"discovery on C "
                f"(`--effects {GEAR_Q2}`)",
                *cells[4],
            ],
        ],
    )


@functools.cache
def ur10_sessions(effects: str | None = None) -> dict:
    """``calibench fit arm-cmm`` on the four series with ``--leave-one-out``: its fit.json."""
    out = scratch() / "sessions" / (effects or "physics")
    args = ["fit", "arm-cmm", *series("A", "B", "C", "D"), "--arm", UR10 / "ur10.toml"]
    args += ["--leave-one-out", "--out", out] + (["--effects", effects] if effects else [])
    calibench(*args)
    return json.loads((out / "fit.json").read_text())


@block(seconds=500, ci=False)
def ur10_sessions_table():
    """calibench fit arm-cmm ur10_A.csv ur10_B.csv ur10_C.csv ur10_D.csv --leave-one-out: each
    series scored by a calibration on the other three, with physics and with the effects discovery
    finds on those three (--effects discover)."""
    from calibench.scenarios.arm_cmm.fit import REGISTER_FRACTION

    fits = [ur10_sessions(), ur10_sessions("discover")]
    order = ("ur10_A.csv", "ur10_B.csv", "ur10_C.csv", "ur10_D.csv")
    rows = []
    for label, f in zip(("`--model physics`", "with `--effects discover`"), fits):
        cells = [
            f"{e['mean_mm']:.3f} / {e['max_mm']:.2f}" + (" (in-sample)" if e["in_sample"] else "")
            for e in (f["leave_one_out"][c] for c in order)
        ]
        rows.append([label, *cells])
    others = len(order) - 1
    return table(
        [
            f"each series left out: trained on the other {others}, its frame registered on "
            f"{percent(REGISTER_FRACTION)} of its rows, scored on the rest (mean / max, mm)",
            *[c.removeprefix("ur10_").removesuffix(".csv") for c in order],
        ],
        rows,
    )


@block(seconds=900, ci=False)
def ur10_sessions_floor():
    """The floor under the table above: each series left out as there, with the effects
    discovery finds on the other three, but its frame and own terms fitted by least squares on
    the rows that score it (``leave_one_session_out(..., register_on_scored=True)``): in-sample,
    the lowest RMS any registration of that calibration leaves on them."""
    from calibench.scenarios.arm_cmm.sessions import leave_one_session_out

    order = ("A", "B", "C", "D")
    out = scratch() / "sessions" / "floor"
    floor = leave_one_session_out(
        series(*order), UR10 / "ur10.toml", None, out, "discover", register_on_scored=True
    )["leave_one_out"]
    held = ur10_sessions("discover")["leave_one_out"]
    rows = []
    for label, f in (
        ("registered on a fifth of its rows, scored on the rest (the table above)", held),
        ("registered on the rows it scores (in-sample: the floor)", floor),
    ):
        for key, what in (("rms_mm", "RMS"), ("mean_mm", "mean")):
            rows.append([f"{label}: {what}", *[f"{f[f'ur10_{c}.csv'][key]:.3f}" for c in order]])
    return table(["with the effects discovery finds on the other three (mm)", *order], rows)
