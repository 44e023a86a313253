"""Recordings of one machine end to end: the columns that number or time a recording's rows
(passes, turns, seconds) continued from one recording to the next, so that no two recordings
share a pass and time never runs back."""

from __future__ import annotations

import numpy as np


def labels_end_to_end(labels: list[np.ndarray]) -> np.ndarray:
    """Each recording's labels (a pass, a turn) renumbered 0, 1, ... in their sorted order, and
    continued where the previous recording's stopped.

    Parameters
    ----------
    labels : one (n_i,) array per recording.

    Returns
    -------
    (sum n_i,) int
    """
    out, first = [], 0
    for lab in labels:
        ids = np.unique(lab, return_inverse=True)[1].reshape(-1)
        out.append(ids + first)
        first += int(ids.max(initial=-1)) + 1
    return np.concatenate(out)


def times_end_to_end(times: list[np.ndarray]) -> np.ndarray:
    """Each recording's times (s) moved to start one median sample step after the previous
    recording's last (a recording of one row steps 1 s).

    Parameters
    ----------
    times : one (n_i,) array per recording.

    Returns
    -------
    (sum n_i,) float
    """
    out, start = [], 0.0
    for t in times:
        t = np.asarray(t, float)
        out.append(t - t[0] + start)
        step = float(np.median(np.diff(t))) if len(t) > 1 else 1.0
        start = float(out[-1].max()) + step
    return np.concatenate(out)
