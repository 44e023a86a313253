"""Which rows of which recording chose a model's structure, which fitted it and which scored it.

Evidence never chooses and scores on the same rows. ``discover`` chooses a model's structure
(its candidates, frequencies, band edges) on the rows it reads; ``fit`` fits parameters on its
training rows and scores held-out and test rows. Both record, per recording, the three sets
(docs/formats.md, "Provenance"): ``{"file": name, "sha256": .., "rows": {"chose": .., "fitted": ..,
"scored": ..}}``, each set as half-open ranges of data rows, row 0 the first data row. A file is
known by its content's hash, so a renamed copy is the same recording and an edited one is not.

A score on rows that chose the structure is in-sample: ``fit --effects FILE`` looks up FILE's
provenance and writes such a score under ``in_sample``, never beside held-out figures.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

import numpy as np

ROLES = ("chose", "fitted", "scored")


def ranges(rows) -> list[list[int]]:
    """Row indices as sorted half-open ranges ``[[start, stop], ...]`` (duplicates merged)."""
    r = np.unique(np.asarray(rows, dtype=np.int64).ravel())
    if len(r) == 0:
        return []
    breaks = np.flatnonzero(np.diff(r) != 1)
    starts = np.r_[r[0], r[breaks + 1]]
    stops = np.r_[r[breaks] + 1, r[-1] + 1]
    return [[int(a), int(b)] for a, b in zip(starts, stops)]


def rows_in(spans: list[list[int]]) -> np.ndarray:
    """The row indices (k,) of half-open ranges, sorted."""
    if not spans:
        return np.empty(0, np.int64)
    return np.concatenate([np.arange(a, b, dtype=np.int64) for a, b in spans])


def file_sha256(path: Path) -> str:
    """The hex SHA-256 of a file's bytes: a recording's identity, whatever its name."""
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def entry(path: Path, chose=(), fitted=(), scored=()) -> dict:
    """One recording's provenance: its name, its hash and the three sets of rows."""
    return {
        "file": Path(path).name,
        "sha256": file_sha256(Path(path)),
        "rows": {"chose": ranges(chose), "fitted": ranges(fitted), "scored": ranges(scored)},
    }


def chosen_rows(provenance: list[dict] | None, path: Path) -> np.ndarray | None:
    """The rows of the recording at ``path`` that chose the structure, by the recorded
    provenance (a discovery.json's ``provenance``): none when it does not name this recording
    (its content's hash), None when there is no provenance to say."""
    if not provenance:
        return None
    sha = file_sha256(Path(path))
    found = [e for e in provenance if e.get("sha256") == sha]
    if not found:
        return np.empty(0, np.int64)
    return np.unique(np.concatenate([rows_in(e["rows"]["chose"]) for e in found]))


def overlap(scored_rows: np.ndarray, chose: np.ndarray | None) -> int:
    """How many of ``scored_rows`` also chose the structure (0 when nothing is known to have)."""
    if chose is None or len(chose) == 0:
        return 0
    return int(np.isin(np.asarray(scored_rows), chose).sum())


def chose_by_effects(effects, run_discovery: bool):
    """``chosen_by(path, training_rows)``: the rows of the recording at ``path`` that chose the
    model's structure. With ``--effects FILE``, FILE's provenance says (None: FILE does not say,
    so no score of this fit can be shown to be held out); with ``--effects discover``, the
    discovery ran on the training rows here; without effects, none did."""
    if effects is None:
        return lambda path, training: np.empty(0, np.int64)
    if run_discovery:
        return lambda path, training: (
            np.empty(0, np.int64) if training is None else np.flatnonzero(training)
        )
    try:
        d = json.loads(Path(effects).read_text())
    except (OSError, ValueError):
        d = {}
    recordings = (d.get("provenance") or {}).get("recordings")
    if not recordings:
        return lambda path, training: None
    return lambda path, training: chosen_rows(recordings, path)


def chose_or_none(chosen_by, path, training) -> np.ndarray:
    """The rows that chose the structure, for fit.json's provenance (unknown: none listed)."""
    rows = chosen_by(path, training)
    return np.empty(0, np.int64) if rows is None else rows


def record_score(result: dict, kind: str, label: str, figs: dict, rows: np.ndarray, chose) -> None:
    """A score of ``rows`` under ``kind`` (holdout, test), or under ``in_sample`` with why,
    when rows of its recording chose the model's structure or nobody can say they did not."""
    n = overlap(rows, chose)
    if chose is not None and n == 0:
        result.setdefault(kind, {})[label] = figs
        return
    why = (
        "the effects file does not say which rows chose its structure"
        if chose is None
        else f"{n} of these rows chose the model's structure (the effects' discovery read them)"
    )
    result.setdefault("in_sample", {})[label] = {**figs, "was": kind, "why": why}
