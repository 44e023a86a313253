"""A structure discover chose, scored on a fresh recording of the same machine: rows that chose
nothing.

discover's own held-out figures (``cv_rms_*``) are the selection's folds: it accepts an effect
only where it lowers them, so they are in-sample for the structure. Here the effects one
recording chose (their families, the periods and harmonics fixed there or searched again on each
fold's training rows, the tables' bands) are fitted on another recording of the same machine,
fold by fold, and scored on its held-out rows, beside the scene model alone on the same folds.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from typing import Any

import numpy as np

from calibench.estimators.discovery.fit import Signal, cv_residuals

SCENE_MODEL = ("geometry",)  # what a user calibrates anyway: the scene model's, not a finding


@dataclasses.dataclass
class FreshScore:
    """The fresh recording's held-out RMS (mm) with the scene model alone and with the chosen
    effects, over ``rows`` residual rows; ``not_carried``: the chosen effects whose columns are
    tied to the first recording's rows (a table over stations another plan does not visit)."""

    cv_rms_scene_model: float
    cv_rms_with_effects: float
    rows: int
    not_carried: list[str]


def structure(terms: dict, drivers: Mapping[str, Any], fold: np.ndarray) -> dict:
    """What a plug-in's figure data carries for :func:`score_on_fresh`: the accepted terms per
    axis (``{axis: [term, ...]}``), the drivers and the folds (per sample)."""
    return {"terms": terms, "drivers": drivers, "fold": fold}


def _carries(term, sig: Signal, drivers: dict) -> bool:
    if hasattr(term, "fix"):  # a search: fixed again on the fresh rows' training folds
        return True
    return term.columns(drivers).shape[0] == len(sig.r)


def score_on_fresh(chosen: dict, fresh: dict) -> FreshScore:
    """The structure ``chosen`` (a plug-in's figure data, :func:`structure`) scored on the
    recording of ``fresh`` (the same plug-in's figure data of another recording of the machine):
    each fold of the fresh recording predicted by a fit to its others, once with the scene
    model's terms alone and once with every chosen effect.

    Returns
    -------
    FreshScore
        Both RMS over all the fresh recording's residual rows (every signal).
    """
    drivers, fold = fresh["drivers"], fresh["fold"]
    sq_scene = sq_all = 0.0
    rows = 0
    left: list[str] = []
    for sig in fresh["signals"]:
        terms = chosen["terms"].get(sig.axis, [])
        kept = [t for t in terms if _carries(t, sig, drivers)]
        left += [t.key for t in terms if not any(t is k for k in kept)]
        scene = [t for t in kept if t.name in SCENE_MODEL]
        sq_scene += float(np.sum(cv_residuals(sig, scene, drivers, fold, {}) ** 2))
        sq_all += float(np.sum(cv_residuals(sig, kept, drivers, fold, {}) ** 2))
        rows += len(sig.r)
    return FreshScore(float(np.sqrt(sq_scene / rows)), float(np.sqrt(sq_all / rows)), rows, left)
