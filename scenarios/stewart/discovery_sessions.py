"""Several recordings of one Stewart platform, fitted as one.

What one recording cannot show a second one can: a leg's thermal growth in a room that barely
warmed is a scale of the leg's length that the hinges take in part, and the same platform
recorded warmer separates it. The recordings may come from different tracker stations: each is
registered on the nominal platform and its poses are taken into the first recording's tracker
frame; the discovery then gives each recording's frame its own six columns (the registration's
remainder) and fits one set of hinges to all. A recording of another platform is refused
(:mod:`same_machine`).
"""

from __future__ import annotations

import numpy as np

from calibench.recordings.joining import times_end_to_end
from calibench.recordings.records import StewartRecording


def joined(recs: list, geometry, register) -> tuple[StewartRecording, np.ndarray]:
    """The recordings as one, in the first recording's tracker frame.

    Parameters
    ----------
    recs : list of StewartRecording
        Two or more recordings of one platform.
    geometry
        The platform's nominal geometry (``StewartGeometry``).
    register : callable
        ``register(rec, geometry) -> (R (3, 3), t (3,))``: a recording's tracker-to-base frame on
        the nominal platform.

    Returns
    -------
    recording : StewartRecording
        Every pose, the later recordings' taken into the first's tracker frame; an optional
        column only where every recording has it; times run on from one recording to the next.
    rec_id : ndarray
        (n,) the recording of each pose, 0 the first.
    """
    frames = [register(r, geometry) for r in recs]
    R1, t1 = frames[0]
    R_all, t_all = [], []
    for r, (Rf, tf) in zip(recs, frames):
        M, c = R1.T @ Rf, R1.T @ (tf - t1)  # this tracker's frame -> the first's
        R_all.append(np.einsum("ij,njk->nik", M, r.R))
        t_all.append(r.t_mm @ M.T + c)

    def column(name):
        cols = [getattr(r, name) for r in recs]
        return None if any(c is None for c in cols) else np.concatenate(cols)

    t_s = times_end_to_end([r.t_s for r in recs]) if all(r.t_s is not None for r in recs) else None
    rec = StewartRecording(
        np.vstack([r.readings_mm for r in recs]),
        np.concatenate(R_all),
        np.vstack(t_all),
        t_s,
        column("temp_c"),
        column("direction"),
        column("load_n"),
    )
    return rec, np.concatenate([np.full(len(r), k) for k, r in enumerate(recs)])


def frame_per_recording(frame: np.ndarray, rec_id: np.ndarray) -> np.ndarray:
    """The tracker frame's columns (6 n, 6) split into each recording's own (6 n, 6 k)."""
    row_rec = np.repeat(rec_id, 6)
    return np.hstack([frame * (row_rec == k)[:, None] for k in range(int(rec_id.max()) + 1)])
