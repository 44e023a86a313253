"""Is a finding confirmed under every held-out scheme the recording allows?

A stage's grid of one pass can be held out by whole rows or whole columns. An effect accepted
holding out rows may only interpolate the columns it was fitted on: held out by columns, it gains
nothing. :func:`confirm` reruns the discovery under the grid's other direction (when no scheme
is asked by ``--holdout``) and marks each effect ``confirmed`` when every scheme tried accepts
it, ``not confirmed`` otherwise, with the schemes that did not and why.
"""

from __future__ import annotations

from calibench.errors import BadInput

# a held-out scheme -> the other it is checked against: a grid's rows against its columns (an
# effect fitted on a few columns may only interpolate them). Several passes are held out whole,
# every position seen again in another pass: checked by that scheme alone, so a multi-pass
# recording's discovery costs no more
OTHER_SCHEME = {"leave one row (y) out": "columns", "leave one column (x) out": "rows"}


def confirm(found_by, scenario: str, rec, seed: int, holdout, cfg, arm, out: dict) -> None:
    """Mark ``out``'s effects confirmed or not across the held-out schemes (in place).

    Parameters
    ----------
    found_by : module
        The scenario's discovery plug-in (its ``discover`` and ``HOLDOUTS``).
    scenario, rec, seed, holdout, cfg, arm
        As the discovery that made ``out`` was run.
    out : dict
        Its discovery.json; gains ``holdout_schemes`` (the schemes tried) and, per effect,
        ``status`` and ``not_confirmed_under`` (scheme -> why).
    """
    tried = {out["holdout"]: out}
    if holdout is None and found_by.HOLDOUTS and out["holdout"] in OTHER_SCHEME:
        try:
            other, _ = found_by.discover(
                scenario, rec, seed, OTHER_SCHEME[out["holdout"]], cfg, arm
            )
            tried[other["holdout"]] = other
        except BadInput:  # not a grid that way
            pass
    out["holdout_schemes"] = list(tried)
    for e in out["effects"]:
        missed = {}
        for scheme, o in tried.items():
            if not any(f["name"] == e["name"] and f["axis"] == e["axis"] for f in o["effects"]):
                missed[scheme] = o["not_accepted"].get(
                    f"{e['name']}:{e['axis']}", "not accepted there"
                )
        e["status"] = "not confirmed" if missed else "confirmed"
        e["not_confirmed_under"] = missed


def status_words(e: dict, schemes: list[str]) -> str:
    """The console's words for an effect's status."""
    if e.get("status") is None:
        return ""
    if e["status"] == "confirmed":
        n = len(schemes)
        return f"confirmed ({'under every held-out scheme tried: ' if n > 1 else ''}" + (
            ", ".join(schemes) + ")"
        )
    return "NOT CONFIRMED: " + "; ".join(
        f"{scheme}: {why}" for scheme, why in e["not_confirmed_under"].items()
    )
