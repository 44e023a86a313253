"""The second concealed-effect suite (issue 36): effects no candidate writes down (presliding
friction, a scale that warms behind a lag, a rail joined with a step, a Stewart leg whose hinges
stick and slip, a Stewart leg's sensor warming up, a laser tracker reading through warming air,
a plate's wall that gives where it is thin, an arm's strain-wave gear that stiffens as it winds
up and whose kinematic error grows with the load, an arm link of two segments on springs that
bends under what it carries, an arm's pedestal warming up), each under noise that breaks the
estimators' assumption (Student t with 3 degrees of freedom, a slow drift, gross outliers),
through discover blind and scored against the sealed manifests afterwards, and its structure
scored again on a fresh recording of each machine (scenarios/discover/suite_unwritten.py)."""

import numpy as np

from calibench.scenarios.discover.suite_unwritten import (
    run_unwritten,
    score_unwritten,
    unwritten_cases,
    unwritten_table,
)
from calibench.scenarios.probe_scanner.discovery import discover_scanner
from calibench.sim.concealed import scanner_recording
from calibench.sim.concealed.noise import MISSPECIFIED
from docs.figures.discovery_unwritten import unwritten_table as unwritten_table_words
from docs.figures.engine import readme_disagrees


def test_unwritten_effects_under_misspecified_noise():
    results = [run_unwritten(*case) for case in unwritten_cases()]
    print(unwritten_table(results))
    scores = score_unwritten(results)
    print(scores)
    assert {r.noise for r in results} == set(MISSPECIFIED)
    assert set(scores) == {"belt-stage", "vision-stage", "probe-scanner", "stewart", "arm-cmm"}
    for scenario, s in scores.items():
        assert s["detection"] >= 0.9, (scenario, s)
        assert s["null_false_claim_rate"] <= 0.05, (scenario, s)
        assert s["spurious_claims"] <= 1, (scenario, s)
        assert s["improved"] == 1.0, (scenario, s)
        # held out for the structure too: a fresh recording of the same machine (rows that
        # chose nothing) is predicted better with what the first chose, on every effect recording
        assert s["improved_fresh"] == 1.0, (scenario, s)
        assert s["nulls_worse_fresh"] == 0, (scenario, s)
    for r in results:  # the same plan: every chosen effect carries to the fresh recording
        assert r.fresh.not_carried == [], (r.scenario, r.kind, r.fresh)
    # the README's discover-unwritten block, checked on this run (the figures check leaves it here)
    assert not readme_disagrees("discover-unwritten", unwritten_table_words(scores))


def _angles(where: str) -> set[int]:
    """The whole degrees of "at table angles 10-20, 40-45 deg"."""
    out: set[int] = set()
    for run in where.removeprefix("at table angles ").removesuffix(" deg").split(", "):
        lo, hi = (float(v) for v in run.split("-"))
        out |= set(range(int(lo), int(hi)))
    return out


def test_located_and_the_effect_name_the_same_place_on_the_turn():
    """A thin wall ground over 38 deg at 339 deg (with gross readings): `located` names angles
    inside the arc, where the `nonsmooth` table is, never "over the whole turn" beside it; a
    runout, which lives on the whole turn, is said to."""
    rec, manifest = scanner_recording("thin_wall", 9102, noise="outliers")
    out, _ = discover_scanner(rec, 0)
    truth = manifest["effects"][0]["params"]
    arc = {
        int(a) % 360 for a in truth["theta_deg"] + np.arange(-0.5, 0.5, 0.01) * truth["width_deg"]
    }
    where = [d["where"] for d in out["located"] if d["driver"] == "theta_deg"]
    assert where and where[0].startswith("at table angles"), out["located"]
    located = _angles(where[0])
    table = [e for e in out["effects"] if e["name"] == "nonsmooth"]
    assert table, out["effects"]
    assert located <= arc, (located, truth)
    assert located & _angles(table[0]["params"]["where"].split(" (")[0]), (where, table)
    rec, _ = scanner_recording("runout", 9102, noise="outliers")
    out, _ = discover_scanner(rec, 0)
    assert [d["where"] for d in out["located"] if d["driver"] == "theta_deg"] == [
        "over the whole turn"
    ], out["located"]
