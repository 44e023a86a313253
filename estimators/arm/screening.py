"""Bad rows of an arm recording, found without any model of the arm.

Two signatures of a reading that is not what the instrument saw at that posture:

- stale: the measured point repeats the previous row's to the last digit while the arm moved
  (a tracker that lost the reflector and reported its last value);
- repeats that disagree: the same posture (every joint within ``q_tol_deg``) visited twice with
  measured points far further apart than the recording's own repeatability (the median distance
  between such repeats). Which of the two is wrong a model has to say; this module only says
  the pair is inconsistent.

Everything here is pure numpy and scipy; rows are 0-based data rows (the CSV's line minus 2).
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy.spatial import cKDTree


@dataclasses.dataclass(frozen=True)
class Screening:
    """stale : (k,) rows whose reading repeats the previous row's.
    pairs : (m, 2) rows of the same posture whose readings disagree, and distance (m,) mm.
    repeatability_mm : median distance between repeated postures (None without repeats).
    n_repeats : how many repeated pairs that median is taken over."""

    stale: np.ndarray
    pairs: np.ndarray
    distance_mm: np.ndarray
    repeatability_mm: float | None
    n_repeats: int


def screen(
    q_rad: np.ndarray,
    xyz_mm: np.ndarray,
    q_tol_deg: float = 0.05,
    factor: float = 10.0,
    floor_mm: float = 0.1,
    tool: np.ndarray | None = None,
) -> Screening:
    """Stale rows and disagreeing repeats of a recording: q (n, N) rad, xyz (n, 3) mm, each row
    of a branched arm's ``tool`` (n,) (None: one tool). Rows of one posture that measure
    different tools are no repeats.

    A repeat disagrees when its distance exceeds ``factor`` times the median repeat distance
    and ``floor_mm``."""
    q = np.degrees(np.asarray(q_rad, float))
    if tool is not None:  # another tool: as far as another posture
        q = np.c_[q, 1e6 * q_tol_deg * np.asarray(tool, float)]
    y = np.asarray(xyz_mm, float)
    moved = np.any(np.abs(np.diff(q, axis=0)) > q_tol_deg, axis=1)
    same = np.all(np.diff(y, axis=0) == 0, axis=1)
    stale = np.flatnonzero(moved & same) + 1
    pairs = (
        cKDTree(q).query_pairs(q_tol_deg, p=np.inf, output_type="ndarray")
        if len(q) > 1
        else np.zeros((0, 2), int)
    )
    if len(pairs) == 0:
        return Screening(stale, np.zeros((0, 2), int), np.zeros(0), None, 0)
    dist = np.linalg.norm(y[pairs[:, 0]] - y[pairs[:, 1]], axis=1)
    rep = float(np.median(dist))
    bad = dist > max(factor * rep, floor_mm)
    return Screening(stale, pairs[bad], dist[bad], rep, len(pairs))
