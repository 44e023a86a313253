"""Head to head: an accepted mechanism is named only when it beats its look-alikes on held-out
rows.

Forward selection accepts the candidate that cuts the held-out RMS most; a look-alike (for a
joint: lost motion, an eccentricity, a harmonic, a step) may fit almost as well, and then the
recording cannot say which mechanism acts. Each accepted term ``t`` of a signal meets every
rival ``c`` the instrument offers for the same axis (and joint), ``c`` put in ``t``'s place with
every other term kept. With ``e_t`` and ``e_c`` the held-out residuals (m,) of the two models, the
per-sample paired difference

    d_s = sum over the sample's rows of (e_c^2 - e_t^2)

measures what ``t`` explains that ``c`` does not; ``t`` beats ``c`` when

    z = mean(d) / (std(d) / sqrt(S)) >= BEATS_Z,    S samples,

and ``c`` leaves a held-out RMS at least :data:`MARGIN` above ``t``'s (the rows share each
fold's fit, so z alone calls a difference of a few parts in ten thousand real):

    |e_c| >= (1 + MARGIN) |e_t|.

A term that does not beat its strongest rival is confounded with it: the model keeps what they
share (the held-out RMS is the same with either), the report names neither.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable
from typing import Any

import numpy as np

from calibench.estimators.discovery.effect import Drivers
from calibench.estimators.discovery.fit import Signal, cv_residuals

BEATS_Z = 2.0  # standard errors by which a named mechanism beats its strongest look-alike
MARGIN = 0.01  # and by this share of the held-out RMS: a look-alike that leaves 1 % more ties
# what claims a physical mechanism, and so must beat the others: smooth maps, geometry and
# tables describe, they do not name one
MECHANISMS = frozenset(
    {
        "backlash",
        "reversal_transient",
        "encoder_eccentricity",
        "periodic",
        "runout",
        "joint_compliance",
        "step",
        "thermal_expansion",
        "thermal_drift",
    }
)


@dataclasses.dataclass(frozen=True)
class Duel:
    """An accepted ``term`` against its strongest ``rival``: the held-out RMS with each in the
    model (mm) and the paired z of the term's advantage (see the module's equation)."""

    term: Any
    rival: Any
    axis: str
    cv_term: float
    cv_rival: float
    z: float

    @property
    def named(self) -> bool:
        """Whether the term beats the rival: else they are confounded."""
        return self.z >= BEATS_Z and self.cv_rival >= (1 + MARGIN) * self.cv_term


def _same_place(a, b) -> bool:
    return a.axis == b.axis and all(
        getattr(a, where, None) == getattr(b, where, None) for where in ("joint", "leg")
    )


def duel(sig: Signal, terms: list, index: int, rival, drivers: Drivers, fold: np.ndarray) -> Duel:
    """``terms[index]`` of ``sig`` against ``rival`` in its place (module's equation)."""
    cache: dict = {}
    e_t = cv_residuals(sig, terms, drivers, fold, cache)
    swapped = terms[:index] + [rival] + terms[index + 1 :]
    e_c = cv_residuals(sig, swapped, drivers, fold, {})
    samples, at = np.unique(sig.sample, return_inverse=True)
    d = np.bincount(at, e_c**2 - e_t**2, minlength=len(samples))
    spread = float(np.std(d, ddof=1)) if len(d) > 1 else 0.0
    mean = float(np.mean(d))
    if spread > 0:
        z = mean / (spread / np.sqrt(len(d)))
    else:
        z = np.inf if mean > 0 else 0.0
    return Duel(
        terms[index],
        rival,
        sig.axis,
        float(np.sqrt(np.mean(e_t**2))),
        float(np.sqrt(np.mean(e_c**2))),
        float(z),
    )


def ties(
    signals: list[Signal],
    terms: dict[str, list],
    candidates: Iterable,
    drivers: Drivers,
    fold: np.ndarray,
) -> list[Duel]:
    """The accepted mechanisms (:data:`MECHANISMS`) that do not beat their strongest look-alike
    among ``candidates`` (those of the same axis and joint, of another name, not accepted): each
    one's duel with that rival, in the order of the signals and their terms.

    The strongest rival is the one with the lowest held-out RMS in the term's place.
    """
    pool = list(candidates)
    out = []
    for sig in signals:
        accepted = {t.key for t in terms[sig.axis]}
        for i, t in enumerate(terms[sig.axis]):
            if getattr(t, "name", "") not in MECHANISMS:
                continue
            rivals = [
                c
                for c in pool
                if c.name in MECHANISMS
                and c.name != t.name
                and c.key not in accepted
                and _same_place(c, t)
            ]
            duels = [duel(sig, terms[sig.axis], i, c, drivers, fold) for c in rivals]
            if duels:
                strongest = min(duels, key=lambda d: d.cv_rival)
                if not strongest.named:
                    out.append(strongest)
    return out
