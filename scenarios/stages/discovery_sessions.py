"""Several recordings of one stage, discovered together: the same machine's error map, each
recording's passes its own, its temperatures where they were.

A thermal expansion is a scale error that changes with the temperature: on one recording whose
room barely moved it is one number with the scale the error map already has (discover says so,
with the experiment: repeat the test warm and cold). A second recording of the same machine in a
warmer room makes the two differ, and fitted together they are told apart.
"""

from __future__ import annotations

import numpy as np

from calibench.recordings import StageRecording
from calibench.recordings.joining import labels_end_to_end, times_end_to_end
from calibench.scenarios.report import BadInput


def joined(recs: list[StageRecording]) -> StageRecording:
    """The recordings end to end: passes renumbered to stay apart (a recording without ``run``
    is one pass), times running on from one to the next. An optional column is kept only where
    every recording has it; ``temp_c`` must be in all or none (a thermal effect needs it
    throughout)."""
    if len(recs) == 1:
        return recs[0]
    has = {f: [getattr(r, f) is not None for r in recs] for f in StageRecording.OPTIONAL}
    if any(has["temp_c"]) and not all(has["temp_c"]):
        raise BadInput(
            "some recordings log temp_c and some do not: discover needs the temperature in all "
            "of them, or in none"
        )

    def cat(name: str):
        return np.concatenate([getattr(r, name) for r in recs]) if all(has[name]) else None

    return StageRecording(
        x_cmd_mm=np.concatenate([r.x_cmd_mm for r in recs]),
        y_cmd_mm=np.concatenate([r.y_cmd_mm for r in recs]),
        x_meas_mm=np.concatenate([r.x_meas_mm for r in recs]),
        y_meas_mm=np.concatenate([r.y_meas_mm for r in recs]),
        t_s=times_end_to_end([r.t_s for r in recs if r.t_s is not None])
        if all(has["t_s"])
        else None,
        dir_x=cat("dir_x"),
        dir_y=cat("dir_y"),
        temp_c=cat("temp_c"),
        run=labels_end_to_end([np.zeros(len(r)) if r.run is None else r.run for r in recs]).astype(
            float
        ),
    )


# The most two recordings' error maps may differ beyond a scale and a zero, as the RMS over the
# rows (mm): the same machine, repeated or 4 K warmer, differs by 0.03-0.09 um under every noise of
# the suites (a slow drift included); another machine of the same model, its as-built map drawn
# anew, by 0.66-2.4 um. (An F test against the residual does not separate them: a slow drift
# projects onto the map's curvature, and the same machine under it reaches F = 70.)
SAME_MAP_MM = 0.3e-3


def map_difference(recs: list[StageRecording], degree: int) -> np.ndarray:
    """How far the recordings' error maps of ``degree`` in (x, y) differ beyond what each may
    have of its own (its scale and zero: the terms of degree 0 and 1, a warmer room, a re-homed
    axis): one map shared against each recording's own, each pass its own offset in both.

    Returns
    -------
    rms_mm : (n_recordings,) ndarray
        Each recording's map difference, the RMS over its rows and axes of what the shared map
        leaves beyond the separate maps (mm).
    """
    from calibench.scenarios.stages.discovery import poly_base

    rec = joined(recs)
    which = np.repeat(np.arange(len(recs)), [len(r) for r in recs])
    span = (max(np.ptp(rec.x_cmd_mm), 1.0), max(np.ptp(rec.y_cmd_mm), 1.0))
    P = poly_base(rec.x_cmd_mm, rec.y_cmd_mm, degree, span)
    own = [(which == k).astype(float)[:, None] for k in range(len(recs))]
    assert rec.run is not None  # joined() numbers every recording's passes
    passes = np.unique(rec.run, return_inverse=True)[1].ravel()
    offsets = (passes[:, None] == np.arange(passes.max() + 1)[None, :]).astype(float)
    shared = np.hstack([P] + [P[:, :3] * o for o in own[1:]] + [offsets])
    separate = np.hstack([P * o for o in own] + [offsets])
    sq = {}
    for name, X in (("shared", shared), ("separate", separate)):
        sq[name] = sum(
            (e - X @ np.linalg.lstsq(X, e, rcond=None)[0]) ** 2
            for e in (rec.x_meas_mm - rec.x_cmd_mm, rec.y_meas_mm - rec.y_cmd_mm)
        )
    extra = sq["shared"] - sq["separate"]  # a row's may be negative, a recording's is not
    return np.array([np.sqrt(max(np.mean(extra[which == k]), 0.0) / 2) for k in range(len(recs))])


def same_machine(recs: list[StageRecording], degree: int) -> None:
    """BadInput unless every recording's error map is the first's, up to its own scale and zero
    (:func:`map_difference`): a recording of another machine would be fitted as this one's."""
    if len(recs) < 2:
        return
    rms_mm = map_difference(recs, degree)
    k = int(np.argmax(rms_mm))
    if rms_mm[k] > SAME_MAP_MM:
        who = (
            "the two recordings are not of the same machine: their error maps differ"
            if len(recs) == 2
            else f"recording {k + 1} is not of the same machine as the others: its error map "
            "differs from theirs"
        )
        raise BadInput(
            f"{who} by {1000 * rms_mm[k]:.2f} um RMS beyond a scale and a zero (one "
            f"machine's, warmer or not, agree within {1000 * SAME_MAP_MM:g} um): give "
            "recordings of one stage"
        )
