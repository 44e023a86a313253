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
        t_s=times_end_to_end([r.t_s for r in recs]) if all(has["t_s"]) else None,
        dir_x=cat("dir_x"),
        dir_y=cat("dir_y"),
        temp_c=cat("temp_c"),
        run=labels_end_to_end([np.zeros(len(r)) if r.run is None else r.run for r in recs]).astype(
            float
        ),
    )
