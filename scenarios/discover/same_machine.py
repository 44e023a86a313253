"""Several recordings of an arm or a Stewart platform: are they of one machine?

discover fits one geometry (an arm's chain, a platform's hinges) to all its recordings, each in
its own frame, so that a second recording can separate what one alone cannot (a compliance from
an eccentricity with the elbow held elsewhere, a leg's growth from its scale in a warmer room). A
recording of another machine of the same drawing would then be fitted as if one: its own errors
taken, in part, by whatever the candidates offer. So each recording after the first is given a
geometry of its own beside the shared one, and how far that moves its readings says whether the
machine is the same.
"""

from __future__ import annotations

import numpy as np

from calibench.estimators.discovery.effect import Drivers
from calibench.estimators.discovery.fit import Signal, fit_terms, lstsq, prior_rows
from calibench.scenarios.report import BadInput

# RMS per coordinate (mm) by which a recording's own geometry may move an arm's points beyond
# the shared one. Measured with a 10 um reference: the same simulated UR10, other postures, a
# gear phase per session or an eccentricity in one session only, 0.001-0.008 mm; the real UR10's
# four series (Landgraf et al., sessions days apart under other loads), together or in pairs,
# 0.011-0.133 mm, leaving 0.16-0.25 mm unexplained; another UR10 of the same drawing (errors of
# the seed's sizes: 0.1 mm, 1 mrad), 0.34-0.81 mm over 22 draws, leaving 0.025-0.053 mm (4 draws).
SAME_ARM_MM = 0.2
# The same for a platform's legs' readings (mm). Measured on the suite's platform (1 um legs, a
# tracker's 2 um): the same platform recorded again, or 3 K warmer from another tracker station,
# under 0.001 mm; another of the same drawing (hinge errors of the scenario's size), 0.12-0.32 mm
# over 4 draws.
SAME_PLATFORM_MM = 0.02
# and beyond this many times what its own geometry leaves on it (see :func:`other_machine`)
EXPLAINED = 3.0


def own_geometry_rms(
    sig: Signal, terms: list, geometry, drivers: Drivers, rec_id: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """How far each recording's own geometry moves its readings beyond the shared geometry, and
    what it then leaves unexplained.

    Parameters
    ----------
    sig : Signal
        The residual (``sig.sample`` the posture or pose of each row; an arm's 3 rows per
        posture, a platform's 6 per pose).
    terms : list
        The accepted terms.
    geometry
        The geometry candidate: the shared geometry, in the terms or not (a mix of two machines
        may leave none accepted).
    drivers : dict
        The candidates' drivers at the postures.
    rec_id : ndarray
        (n_samples,) the recording of each posture or pose, 0 the first.

    Returns
    -------
    moved : ndarray
        (n_recordings,) RMS per row (mm) of the fitted readings' change on each recording's
        rows when every recording after the first takes a geometry of its own (the first
        moves too: the shared geometry is no longer a compromise).
    left : ndarray
        (n_recordings,) RMS per row (mm) of each recording's residual with its own geometry.
    """
    n_rec = int(rec_id.max()) + 1
    if n_rec < 2:
        return np.zeros(1), np.zeros(1)
    terms = [geometry] + [t for t in terms if t.name != "geometry"]
    fixed, coef, _, _ = fit_terms(sig, terms, drivers, {}, None)
    at, k = fixed[0][1:]
    X = np.hstack([sig.base] + [t.columns(drivers) for t, _, _ in fixed])
    row_rec = rec_id[sig.sample]
    own = np.hstack([X[:, at : at + k] * (row_rec == i)[:, None] for i in range(1, n_rec)])
    P = prior_rows(fixed, X.shape[1])
    # the shared geometry keeps its prior; each recording's own deviation from it is free
    X2 = np.c_[X, own]
    P2 = np.c_[P, np.zeros((len(P), own.shape[1]))]
    coef2 = lstsq(np.vstack([X2, P2]), np.r_[sig.r, np.zeros(len(P))])
    moved = X2 @ coef2 - X @ coef
    res = sig.r - X2 @ coef2

    def per_recording(v):
        return np.array([np.sqrt(np.mean(v[row_rec == i] ** 2)) for i in range(n_rec)])

    return per_recording(moved), per_recording(res)


def other_machine(moved: np.ndarray, left: np.ndarray, limit_mm: float) -> int | None:
    """The first recording after the first that is of another machine, or None.

    One is when its own geometry moves its readings beyond ``limit_mm`` and beyond
    :data:`EXPLAINED` times what the model then leaves on it: another machine's recording is
    explained to its noise by a geometry of its own, while a session of the same machine that the
    model fits poorly (a real arm's days-apart sessions under other loads) moves by no more than
    its residual."""
    for k in range(1, len(moved)):
        if moved[k] > limit_mm and moved[k] > EXPLAINED * left[k]:
            return k
    return None


def refuse_another(
    moved: np.ndarray, left: np.ndarray, limit_mm: float, machine: str, geometry: str
) -> None:
    """BadInput naming the first recording of another machine (:func:`other_machine`), if any.

    Parameters
    ----------
    moved, left : ndarray
        (n_recordings,) :func:`own_geometry_rms`'s, mm.
    limit_mm : float
        The machine's limit (:data:`SAME_ARM_MM`, :data:`SAME_PLATFORM_MM`).
    machine, geometry : str
        The words for the machine (``arm``) and its geometry (``link errors``).
    """
    k = other_machine(moved, left, limit_mm)
    if k is not None:
        raise BadInput(
            f"recording {k + 1} is not of recording 1's {machine}: given {geometry} of its own, "
            f"its readings move {moved[k]:.3g} mm (RMS) from the shared fit and {left[k]:.3g} mm "
            f"is left (one {machine}: within {limit_mm} mm, or within {EXPLAINED:g} times what is "
            "left)"
        )
