"""The concealed-effect suite: blinded recordings through ``discover``, scored against their
sealed manifests afterwards. Used by the test (tests/scenarios/test_discover_suite.py) and the
benchmark (benchmarks/discover.py), which print the same figures.

Scoring:
- detection: each concealed effect (by name and axis; the arm's joint and the platform's leg too)
  found;
- false claims: any effect claimed on a null recording (the arm's and the platform's ``geometry``
  is the twin's own model being calibrated, not a concealed effect, and is not counted);
- parameters: within 25 % of the truth (a period within 5 %, a runout's harmonic exactly, a
  bump's or nick's place within 3 widths, a joint's compliance within 3 of its standard errors);
- improvement: where the concealed effects dominate the residual (held-out RMS of the scene
  model at least 2.5 x the reference noise), cv_rms after / before <= 0.5, on the selection's
  own folds: in-sample for the structure the selection chose on them.
"""

from __future__ import annotations

import dataclasses

from calibench.scenarios.discover.engine import plugin
from calibench.scenarios.registry import instruments


def suite_cases() -> tuple[tuple[str, str, int], ...]:
    """The suite's cases (label, kind, seed), instrument by instrument as the registry lists
    them (each instrument's ``suite``; ``NAME:ARM`` for its ``suite_arms``)."""
    return tuple(
        (label, kind, s)
        for row in instruments()
        for label, cases in (
            (row.name, row.suite),
            *((f"{row.name}:{arm}", c) for arm, c in row.suite_arms),
        )
        for kind, seeds in cases
        for s in range(seeds)
    )


def recorded(label: str, kind: str, seed: int, **options) -> tuple[object, dict]:
    """A concealed recording of ``kind`` for a suite's ``label`` (a scenario, or ``NAME:ARM``)
    and its sealed manifest, from the instrument's discovery adapter (its ``concealed``);
    ``options``: the generator's (noise, repeat)."""
    scenario, _, arm = label.partition(":")
    return plugin(scenario).concealed(scenario, kind, seed, arm=arm or None, **options)


def searched(label: str, rec, seed: int, floor: float | None = None) -> tuple[dict, dict]:
    """``discover``'s search on a recording of a suite's ``label`` (its twin nominal), by the
    instrument's adapter (its ``search``): discovery.json's content and the figure's;
    ``floor``: the acceptance floor (None: the instrument's own)."""
    scenario, _, arm = label.partition(":")
    return plugin(scenario).search(scenario, rec, seed, floor=floor, arm=arm or None)


NOT_CONCEALED = ("geometry",)


@dataclasses.dataclass
class CaseResult:
    scenario: str
    kind: str
    seed: int
    truth: list
    found: list
    detected: int
    concealed: int
    false_claims: int
    param_errors: list  # (what, relative error, limit)
    ratio: float | None  # cv after / before, where the concealed effects dominate


def _match(t, f) -> bool:
    if t["name"] != f["name"] or t["axis"] != f["axis"]:
        return False
    return all(
        k not in t["params"] or t["params"][k] == f["params"].get(k) for k in ("joint", "leg")
    )


KINDS = (
    "null",
    "backlash",
    "periodic",
    "thermal",
    "combined",
    "bump",
    "eccentricity",
    "compliance",
    "runout",
    "scale",
    "pitch",
    "mixed",
    "elastic",
    "drift",
)


def case_seed(kind: str, seed: int) -> int:
    """The recording's seed for the suite's case (kind, seed): distinct per kind and seed."""
    return 1000 * seed + 17 + KINDS.index(kind)


NULL_SEED = (
    5000  # the null calibration's recordings: seeds 5000, 5001, ... (apart from the suite's)
)


def null_claims(scenario: str, k: int, floors) -> list[bool]:
    """For the null calibration of the acceptance floor: whether ``discover`` claims any effect
    (the twin's own ``geometry`` aside) on the fresh null recording ``k`` of ``scenario``
    (or ``NAME:ARM``, the instrument with a further arm), at each of ``floors``; one recording,
    every floor."""
    rec, _ = recorded(scenario, "null", NULL_SEED + k)
    return [
        any(e["name"] not in NOT_CONCEALED for e in searched(scenario, rec, 0, f)[0]["effects"])
        for f in floors
    ]


def concealed_discovery(scenario: str, kind: str, seed: int) -> tuple[dict, dict, dict]:
    """The suite's case (scenario, kind, seed) through discover: the sealed manifest,
    discovery.json's content and what the figure needs."""
    rec, manifest = recorded(scenario, kind, case_seed(kind, seed))
    out, fig = searched(scenario, rec, seed)
    return manifest, out, fig


def run_case(scenario: str, kind: str, seed: int) -> CaseResult:
    """Discover on one concealed recording and score it against what was concealed."""
    manifest, out, _ = concealed_discovery(scenario, kind, seed)
    truth = manifest["effects"]
    found = [e for e in out["effects"] if e["name"] not in NOT_CONCEALED]
    detected, errors = 0, []
    for t in truth:
        hit = next((f for f in found if _match(t, f)), None)
        if hit is None:
            continue
        detected += 1
        p, q = t["params"], hit["params"]
        if t["name"] == "backlash":
            errors.append(("reversal", abs(q["reversal_mm"] / p["reversal_mm"] - 1), 0.25))
            if "growth_mm_per_m" in p:  # an elastic belt's: found growing, at the right rate
                g = q.get("growth_mm_per_m", 0.0)
                errors.append(("reversal growth", abs(g / p["growth_mm_per_m"] - 1), 0.25))
            elif "growth_mm_per_m" in q:  # a constant reversal claimed to grow
                errors.append(("reversal growth claimed", 1.0, 0.0))
        elif t["name"] == "periodic":
            errors.append(("period", abs(q["period_mm"] / p["period_mm"] - 1), 0.05))
            errors.append(("amplitude", abs(q["amplitude_mm"] / p["amplitude_mm"] - 1), 0.25))
        elif t["name"] == "runout":
            errors.append(
                ("harmonic", abs(q["harmonic"] - p["harmonic"]), 0.5)
            )  # the very harmonic
            errors.append(("amplitude", abs(q["amplitude_mm"] / p["amplitude_mm"] - 1), 0.25))
        elif t["name"] == "scale":
            errors.append(("ppm", abs(q["ppm"] / p["ppm"] - 1), 0.25))
        elif t["name"] == "leg_compliance":
            errors.append(("um_per_n", abs(q["um_per_n"] / p["um_per_n"] - 1), 0.25))
        elif t["name"] == "thermal_expansion":
            errors.append(("ppm_per_k", abs(q["ppm_per_k"] / p["ppm_per_k"] - 1), 0.25))
        elif t["name"] == "encoder_eccentricity":
            errors.append(("amplitude", abs(q["amplitude_urad"] / p["amplitude_urad"] - 1), 0.25))
        elif (
            t["name"] == "joint_compliance"
        ):  # in standard errors, not relative: the acceptance's 3 std
            z = abs(q["urad_per_nm"] - p["urad_per_nm"]) / max(hit["stderr"]["urad_per_nm"], 1e-300)
            errors.append((f"compliance{p['joint']} (std)", z, 3.0))
        elif t["name"] == "nonsmooth" and "theta_deg" in p:  # a nick in the scanner's plate
            off = (q["theta_deg"] - p["theta_deg"] + 180) % 360 - 180
            errors.append(("nick place (widths)", abs(off) / max(p["width_deg"], 1.0), 3.0))
        elif t["name"] == "nonsmooth":
            where = hit["params"]["where"]
            x_found = float(where.split("largest at x = ")[1].split(" mm")[0])
            errors.append(("bump place (widths)", abs(x_found - p["x_mm"]) / p["width_mm"], 3.0))
    false = sum(1 for f in found if not any(_match(t, f) for t in truth))
    fit = out["fit"]
    before = fit["cv_rms_nominal"]
    geo = [e for e in out["effects"] if e["name"] in NOT_CONCEALED]
    if geo:
        before = geo[-1]["cv_rms_after"]
    noise = manifest["noise_um"] / 1000
    ratio = fit["cv_rms_final"] / before if truth and before >= 2.5 * noise else None
    return CaseResult(
        scenario, kind, seed, truth, found, detected, len(truth), false, errors, ratio
    )


def score(results: list[CaseResult]) -> dict:
    """The suite's figures: detection, false claims on nulls, spurious claims, parameters,
    ratios."""
    nulls = [r for r in results if r.kind == "null"]
    concealed = sum(r.concealed for r in results)
    params = [e for r in results for e in r.param_errors]
    ratios = [r.ratio for r in results if r.ratio is not None]
    return {
        "recordings": len(results),
        "detection": sum(r.detected for r in results) / max(concealed, 1),
        "null_false_claim_rate": sum(r.false_claims > 0 for r in nulls) / max(len(nulls), 1),
        "spurious_claims": sum(r.false_claims for r in results if r.kind != "null"),
        "params_within_limit": sum(e[1] <= e[2] for e in params) / max(len(params), 1),
        "worst_param": max(params, key=lambda e: e[1] / e[2]) if params else None,
        "ratios_ok": sum(x <= 0.5 for x in ratios) / max(len(ratios), 1),
        "worst_ratio": max(ratios) if ratios else None,
        "n_dominated": len(ratios),
    }


def table(results: list[CaseResult]) -> str:
    """The suite's results as a Markdown table."""
    lines = [
        "| scenario | kind | seed | concealed | found | params (rel. error) | cv after/before |",
        "|---|---|---|---|---|---|---|",
    ]
    for r in results:
        found = ", ".join(f"{f['name']}({f['axis']})" for f in r.found) or "-"
        truth = ", ".join(f"{t['name']}({t['axis']})" for t in r.truth) or "-"
        par = ", ".join(f"{w} {e:.3f}" for w, e, _ in r.param_errors) or "-"
        ratio = "" if r.ratio is None else f"{r.ratio:.2f}"
        lines.append(
            f"| {r.scenario} | {r.kind} | {r.seed} | {truth} | {found} | {par} | {ratio} |"
        )
    return "\n".join(lines)
