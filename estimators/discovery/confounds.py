"""Look-alikes: candidates the data cannot tell from the model already accepted.

A candidate whose columns C the scene model and the accepted terms X already span is confounded
with them; the share spanned is

    f = 1 - |C - Q Q^T C|^2 / |C|^2,    Q an orthonormal basis of X, C centred,

and above :data:`CONFOUNDED` the recording cannot say whether the candidate acts. A thermal
expansion is confounded as well when the temperature barely moved: it is then a scale error of the
travel, whatever the columns say. This step decides which candidates are confounded and why, for
every instrument; the instrument's words (``scenarios/<instrument>/discovery*.py``) say it, and
name the experiment that separates them.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable
from typing import Any

import numpy as np

from calibench.estimators.discovery.effect import Drivers
from calibench.estimators.discovery.fit import Signal, confounded

CONFOUNDED = 0.9  # the share of a candidate's columns the accepted model spans: one signal
# a thermal expansion needs the temperature to move by at least this to be told from a scale
MIN_TEMPERATURE_SPAN_K = 1.0


@dataclasses.dataclass(frozen=True)
class Confound:
    """A candidate the recording cannot separate from the accepted model.

    ``fraction``: the share of its columns the model spans; ``cause``: "overlap" (that share is
    above :data:`CONFOUNDED`) or "temperature" (a thermal candidate on a temperature that moved
    only ``temperature_span_k``)."""

    candidate: Any  # an Effect, or another candidate with a name, an axis and a key
    axis: str
    fraction: float
    cause: str
    temperature_span_k: float = 0.0


def find_confounds(
    signals: dict[str, Signal],
    terms: dict[str, list],
    candidates: Iterable,
    drivers: Drivers,
    temp_c: np.ndarray | None = None,
    limit: float = CONFOUNDED,
) -> list[Confound]:
    """The confounded among ``candidates`` (each with an ``axis``), in their order.

    Parameters
    ----------
    signals : the signal of each axis (:class:`~calibench.estimators.discovery.fit.Signal`).
    terms : the accepted terms of each axis.
    candidates : the candidates to ask about (the accepted ones and those meant to overlap, such
        as smooth polynomials, left out by the caller).
    drivers : the drivers the candidates' columns read.
    temp_c : the recording's temperature (n,), or None: then no thermal cause.
    limit : the share above which a candidate is confounded.
    """
    span = None if temp_c is None else float(np.ptp(temp_c))
    out = []
    for c in candidates:
        fraction = confounded(signals[c.axis], terms[c.axis], c, drivers, {})
        if c.name == "thermal_expansion" and span is not None and span < MIN_TEMPERATURE_SPAN_K:
            out.append(Confound(c, c.axis, fraction, "temperature", span))
        elif fraction > limit:
            out.append(Confound(c, c.axis, fraction, "overlap"))
    return out
