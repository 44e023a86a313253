"""``calibench acceptance SCENARIO --test ...``: a standard's acceptance test run on the
scenario's twin, before and after its calibration, with the maker's MPE's verdict when the
config states one (DIR/acceptance.json, docs/formats.md).

Each instrument's registry line names the tests that apply to it; the procedures are its own
(``scenarios/arm_cmm/acceptance.py``: ISO 9283; ``scenarios/arm_cmm/iso10360.py``: ISO
10360-12; ``scenarios/belt_stage/acceptance.py``: ISO 230-2 on each axis). A config's
``[acceptance.mpe]`` table states the maker's maximum permissible errors by the figures' names
(``E_UNI_um = 25``); each figure after calibration is then judged against it.
"""

from __future__ import annotations

import importlib
import json
import math
from collections.abc import Callable
from pathlib import Path

from calibench.scenarios.report import BadInput
from calibench.writing import write_text

ALL_TESTS = ("iso9283", "iso10360-12", "iso230-2")
FIGURES = {  # each test's figures, by the names an MPE states them
    "iso9283": ("AP_mm", "RP_mm"),
    "iso10360-12": ("E_UNI_um", "L_Dia_um", "P_Size_um", "P_Form_um"),
    "iso230-2": tuple(f"{f}_{a}_um" for a in "xy" for f in ("A", "B", "E", "M", "R")),
}


def procedure(scenario: str, test: str) -> Callable[[object, int], dict]:
    """The test's procedure on the scenario's twin, ``(config, seed) -> figures``: the one its
    registry line names (:attr:`~calibench.scenarios.instrument.Instrument.acceptance`)."""
    from calibench.scenarios.registry import instrument

    have = dict(instrument(scenario).acceptance)
    if test not in have:
        its = f"its tests: {', '.join(have)}" if have else "no acceptance test is built for it"
        raise BadInput(f"--test {test} does not apply to {scenario} ({its})")
    module, function = have[test].split(":")
    return getattr(importlib.import_module(module), function)


def stated_mpe(test: str, table: dict) -> dict:
    """The config's ``[acceptance.mpe]`` (``table`` the whole file), checked: a table of positive
    numbers, each named by one of the test's figures."""
    mpe = table.get("acceptance", {})
    if not isinstance(mpe, dict) or not isinstance(mpe.get("mpe", {}), dict):
        raise BadInput("[acceptance.mpe] must be a table of the figures' limits")
    unknown = set(mpe) - {"mpe"}
    if unknown:
        raise BadInput(f"[acceptance] holds {', '.join(sorted(unknown))}: only its mpe table")
    mpe = mpe.get("mpe", {})
    for name, limit in mpe.items():
        if name not in FIGURES[test]:
            raise BadInput(
                f"[acceptance.mpe] states {name}, which {test} does not report (it reports "
                f"{', '.join(FIGURES[test])})"
            )
        if isinstance(limit, bool) or not isinstance(limit, (int, float)) or not limit > 0:
            raise BadInput(f"[acceptance.mpe] {name} = {limit!r}: a positive number")
    return mpe


def judged(figures: dict, mpe: dict) -> dict:
    """Each stated MPE against the figure after calibration (its absolute value): {name: {"mpe",
    "after", "conforms"}}."""
    out = {}
    for name, limit in mpe.items():
        after = abs(float(figures[name]))
        out[name] = {"mpe": float(limit), "after": after, "conforms": after <= limit}
    return out


def real_repeatability(scenario: str, test: str, config, recordings: list[Path]) -> list[dict]:
    """ISO 9283's RP from each real recording's repeated postures (arm-cmm's iso9283 only),
    checked before the twin runs."""
    if not recordings:
        return []
    if (scenario, test) != ("arm-cmm", "iso9283"):
        raise BadInput("--recording: a real arm's RP from its repeated postures (arm-cmm, iso9283)")
    from calibench.scenarios.arm_cmm.repeatability import recording_rp
    from calibench.scenes.arm_cmm import load_arm

    arm = load_arm(config.arm) if isinstance(config.arm, str) else config.arm
    return [recording_rp(p, arm) for p in recordings]


def run_acceptance(
    scenario: str,
    test: str,
    config,
    table: dict,
    seed: int,
    out: Path,
    real: list[dict] | None = None,
) -> dict:
    """Run ``test`` on ``scenario``'s twin (``config`` its scenario config, ``table`` the config
    file's whole content for ``[acceptance]``), with the real recordings' figures ``real``
    (:func:`real_repeatability`) beside it, and write DIR/acceptance.json."""
    mpe = stated_mpe(test, table)
    figures = procedure(scenario, test)(config, seed)
    result = {"scenario": scenario, "test": test, "seed": seed, **figures}
    if real:
        result["recordings"] = real
    if mpe:
        result["mpe"] = judged(figures["after"], mpe)
    for which in ("before", "after"):
        if not all(math.isfinite(v) for v in figures[which].values() if isinstance(v, float)):
            raise RuntimeError(f"acceptance {test}: a figure {which} calibration is not finite")
    write_text(out / "acceptance.json", json.dumps(result, indent=1) + "\n")
    return result
