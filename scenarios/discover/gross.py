"""Gross readings set aside: a discovery run again without the samples that no noise explains.

A laser tracker that lost a reflector's beam for a moment, a speck of dust under a stylus, a
missed encoder count: a reading tens of standard deviations off is not noise, and left in a
least-squares fit it widens or narrows what the stated std should be by its own accident. After a
first discovery the samples holding a reading beyond ``GROSS_SIGMAS`` robust standard deviations
of the residual are set aside, the discovery is run again on the rest, and the report names
them; past ``GROSS_SHARE`` of the samples the model, not the readings, is what is wrong, and
nothing is set aside.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from calibench.estimators.discovery.noise import GROSS_SIGMAS, gross_samples

GROSS_SHARE = 0.2  # more than this are no longer outliers: the model is what is wrong


def without_gross(
    discover: Callable[[list], tuple[dict, dict]], recs: list, what: str
) -> tuple[dict, dict]:
    """``discover(recs)``, and again on ``recs`` without their gross samples if any.

    Parameters
    ----------
    discover : callable
        ``discover(recordings) -> (out, fig)``: ``fig["signals"][0]`` the residual signal whose
        ``sample`` numbers the recordings' samples in order, ``fig["fitted"]`` its residual
        after the model per axis.
    recs : list
        The recordings (each with ``subset(mask)`` and ``len``).
    what : str
        The samples' name in the report (``poses``, ``samples``).

    Returns
    -------
    out, fig
        The discovery's; ``out["set_aside"]`` lists the samples set aside (numbered through the
        recordings in order) and why; ``fig["rows_used"]`` each recording's rows read.
    """
    out, fig = discover(recs)
    sig = fig["signals"][0]
    gross = gross_samples(fig["fitted"][sig.axis], sig.sample)
    lengths = [len(r) for r in recs]
    if not gross.any() or gross.sum() > GROSS_SHARE * len(gross):
        fig["rows_used"] = [np.arange(n) for n in lengths]
        return out, fig
    keep = np.split(~gross, np.cumsum(lengths)[:-1])
    out, fig = discover([r.subset(k) for r, k in zip(recs, keep)])
    out["set_aside"] = {
        what: np.flatnonzero(gross).tolist(),
        "why": f"a residual beyond {GROSS_SIGMAS:g} robust standard deviations: gross readings, "
        "not noise"
        + (f" ({what} numbered through the recordings in order)" if len(recs) > 1 else ""),
    }
    fig["rows_used"] = [np.flatnonzero(k) for k in keep]
    return out, fig
