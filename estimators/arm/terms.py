"""A joint's angle error as known functions of what its drive did: of its own angle (an
encoder's eccentricity, a gear's harmonics, a table of bands) or of the direction it last turned
(the lost motion of a gear, the friction a cable drive leaves).

Each term says the reading is off by ``F @ c`` (rad): the link sits at ``q_j - F @ c``, or, for a
motor's term (``column``, the motor's column of the motor-to-joint coupling), every joint the
motor drives sits at ``q - column (F @ c)``.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from calibench.estimators.discovery.motion import last_direction


@dataclasses.dataclass(frozen=True)
class AngleTerm:
    """A joint's (or a motor's) angle error as a combination of known functions.

    ``kind``: ``harmonic`` (sin and cos of ``harmonic`` q_j: an encoder's eccentricity at 1, a
    gear's harmonics beyond), ``table`` (one value per band of q_j between ``edges_rad``: what no
    law explains) or ``direction`` (half the lost motion b, +b / 2 in the direction the drive
    last turned: ``F = d / 2``, d = +1 / -1, 0 before its first move).
    ``recording``: None for an error every recording shares; an index for one that holds only in
    that recording's rows (a periodic error whose phase is set anew at each power-up: its own
    coefficients per session, none for a session the fit has not seen).
    ``column``: () for a joint's own error; for a motor's (``joint`` then the motor, 1-based) its
    column (N,) of the coupling: the direction is the motor's, and the error turns every joint
    it drives. A cable drive's friction holds the link back by friction over stiffness, in the
    direction the motor last turned: a motor's ``direction`` term.
    """

    joint: int
    kind: str
    harmonic: float = 1.0
    edges_rad: tuple = ()
    label: str = ""
    recording: int | None = None
    column: tuple = ()

    def functions(self, q_joint: np.ndarray, direction: np.ndarray | None = None) -> np.ndarray:
        """F (n, k) at the joint's angles (n,) and its drive's last direction (n,) (needed by a
        ``direction`` term only)."""
        if self.kind == "harmonic":
            h = self.harmonic * np.asarray(q_joint, float)
            return np.stack([np.sin(h), np.cos(h)], axis=1)
        if self.kind == "direction":
            if direction is None:
                raise ValueError(f"{self.names[0]} needs the direction of the drive's last motion")
            return np.asarray(direction, float)[:, None] / 2
        e = np.asarray(self.edges_rad, float)
        band = np.clip(np.searchsorted(e, q_joint, side="right") - 1, 0, len(e) - 2)
        F = np.zeros((len(q_joint), len(e) - 1))
        F[np.arange(len(q_joint)), band] = 1.0
        return F

    @property
    def names(self) -> tuple[str, ...]:
        """Parameter names of the term's coefficients (``angle_<label><joint>_...``)."""
        stem = f"angle_{self.label or self.kind}{self.joint}"
        if self.recording is not None:
            stem += f"_rec{self.recording + 1}"
        if self.kind == "harmonic":
            return (f"{stem}_sin", f"{stem}_cos")
        if self.kind == "direction":
            return (stem,)
        return tuple(f"{stem}_band{k + 1}" for k in range(len(self.edges_rad) - 1))


def directions(
    q_rad: np.ndarray, rec: np.ndarray | None, coupling: np.ndarray | None
) -> np.ndarray:
    """Each joint's and each motor's direction of last motion, (n, 2 N): +1 / -1, 0 before the
    first move of its recording, rows taken in their order (a recording's time order).

    Parameters
    ----------
    q_rad : (n, N) joint readings, in time order within each recording.
    rec : (n,) the recording of each row (its history restarts there), or None: one.
    coupling : (N, N) joint angles = coupling @ motor angles, or None: each motor its joint's.
    """
    q = np.asarray(q_rad, float)
    motors = q if coupling is None else np.linalg.solve(coupling, q.T).T
    return np.stack([last_direction(u, rec) for u in (*q.T, *motors.T)], axis=1).reshape(len(q), -1)
