"""Held-out folds for a recording that has no passes, rows or turns to hold out: blocks of
consecutive samples, contiguous or interleaved.

Five contiguous fifths suit samples in random order (each fifth is a fair draw of the
workspace, and a slow drift is held out whole). A recording taken along a path is another
matter: its fifths are five regions, and a model fitted on four extrapolates into the fifth; the
held-out RMS then ends well above the noise whatever the model. There, the folds are
:data:`INTERLEAVED_BLOCKS` short blocks dealt round-robin to the five folds, so that every
region is in every training set while neighbouring samples (which share a drift or a tracker's
local error) stay held out together.
"""

from __future__ import annotations

import numpy as np

N_FOLDS = 5
INTERLEAVED_BLOCKS = 40
# a path: consecutive samples much nearer each other than two samples drawn at random
PATH_STEP_RATIO = 0.3


def follows_a_path(positions: np.ndarray) -> bool:
    """Whether the samples ``positions`` (n, d) (commanded, in any units: each column scaled by
    its own spread) were taken along a path: the median step between consecutive samples under
    :data:`PATH_STEP_RATIO` of the median distance between two samples drawn at random."""
    p = np.asarray(positions, float).reshape(len(positions), -1)
    p = (p - p.mean(axis=0)) / np.maximum(p.std(axis=0), 1e-12)
    if len(p) < 4 * N_FOLDS:
        return False
    step = np.median(np.linalg.norm(np.diff(p, axis=0), axis=1))
    rng = np.random.default_rng(0)  # a fixed draw: the folds are part of the result
    i, j = rng.integers(0, len(p), (2, 4000))
    spread = np.median(np.linalg.norm(p[i] - p[j], axis=1))
    return bool(step < PATH_STEP_RATIO * spread)


def block_folds(positions: np.ndarray, what: str) -> tuple[np.ndarray, str]:
    """Fold label (n,) per sample and the scheme in words: five contiguous blocks, or, along a
    path, :data:`INTERLEAVED_BLOCKS` blocks dealt round-robin to five folds."""
    n = len(positions)
    if follows_a_path(positions):
        blocks = np.minimum(np.arange(n) * INTERLEAVED_BLOCKS // n, INTERLEAVED_BLOCKS - 1)
        return blocks % N_FOLDS, (
            f"{INTERLEAVED_BLOCKS} interleaved blocks of {what} (the recording follows a path: "
            "contiguous fifths would hold out whole regions and score extrapolation)"
        )
    return np.minimum(np.arange(n) * N_FOLDS // n, N_FOLDS - 1), f"five contiguous blocks of {what}"
