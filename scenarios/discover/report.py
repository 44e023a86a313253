"""What every plug-in's discovery.json says the same way: the accepted effects described from the
final fit, the verdict against the repeatability, the fit and the noise.
"""

from __future__ import annotations

import numpy as np

from calibench.estimators.discovery.fit import (
    fit_terms,
    refined,
)

UNEXPLAINED_RATIO = 1.5  # held-out RMS over repeatability beyond which something is left


def fit_and_noise(
    rms_nominal: float, found, noise: dict | None = None, after_noise: dict | None = None
) -> dict:
    """discovery.json's ``fit`` (the scene model's RMS, its held-out RMS and the final model's)
    and, where the instrument judges by repeats, ``noise`` and ``noise_after_effects`` (the
    repeatability before and after the accepted effects, by axis), written the same way for
    every instrument; ``found`` the selection."""
    out: dict = {
        "fit": {
            "rms_nominal": float(rms_nominal),
            "cv_rms_nominal": found.cv_nominal,
            "cv_rms_final": found.cv_final,
        }
    }
    if noise is not None and after_noise is not None:
        out["noise"] = {
            a: {"repeatability_mm": nz.sigma_mm, "lag1_correlation": nz.lag1, "dof": nz.dof}
            for a, nz in noise.items()
        }
        out["noise_after_effects"] = {
            a: {"repeatability_mm": nz.sigma_mm, "dof": nz.dof} for a, nz in after_noise.items()
        }
    return out


def verdict(cv_final_mm: float, noise: dict, found_any: bool, located: list | None = None) -> str:
    """What is left after the accepted effects, in words: the final held-out RMS (per
    coordinate) against the repeatability from repeats (``noise``: axis -> Noise, after the
    effects). Never a silent stop: unexplained structure, or no repeats to judge by, is said;
    and never "nothing missing" beside structure ``located`` found (the two would contradict)."""
    sig = [nz.sigma_mm for nz in noise.values() if nz.sigma_mm]
    left = cv_final_mm * 1000
    if not sig:
        return (
            f"what is left: {left:.2f} um held out; no station was visited twice, so the "
            "repeatability is unknown and it cannot be said whether that is noise"
        )
    floor = float(np.sqrt(np.mean(np.square(sig)))) * 1000
    if cv_final_mm * 1000 > UNEXPLAINED_RATIO * floor:
        return (
            f"unexplained: {left:.2f} um held out against {floor:.2f} um of repeatability; the "
            "recording holds structure no candidate explains"
        )
    if not found_any and located:
        drivers = ", ".join(sorted({d["driver"] for d in located}))
        return (
            f"near the repeatability ({left:.2f} um held out, {floor:.2f} um from repeats), yet "
            f"the residual follows {drivers} (located): structure no candidate cuts by the "
            "acceptance floor, not noise"
        )
    what = (
        "the accepted effects explain" if found_any else "nothing missing: the scene model explains"
    )
    return (
        f"{what} the recording to its repeatability ({left:.2f} um held out, {floor:.2f} um "
        "from repeats)"
    )


def describe_effects(signals, terms, found, drivers, noise):
    """Each accepted effect's parameters and standard errors from the final all-data fit."""
    by_axis = {s.axis: s for s in signals}
    fitted, described = {}, {}
    for a, sig in by_axis.items():
        nz = noise.get(a)
        sigma = nz.sigma_mm * nz.inflation if nz is not None and nz.sigma_mm else None
        fixed, coef, cov, res = fit_terms(sig, terms[a], drivers, {}, sigma, robust=True)
        again = refined(sig, fixed, drivers)
        if again is not None:
            fixed, coef, cov, res = fit_terms(sig, again, drivers, {}, sigma, robust=True)
        fitted[a] = res
        for term, (t, start, k) in zip(
            terms[a], fixed
        ):  # keyed by the term as selected (a search, fixed here)
            p, e, text = t.describe(
                coef[start : start + k], cov[start : start + k, start : start + k]
            )
            described[id(term)] = (t, p, e, text)
    effects = []
    for st in found.steps:
        t, p, e, text = described[id(st.term)]
        effects.append(
            {
                "name": t.name,
                "axis": st.axis,
                "params": plain(p),
                "stderr": plain(e),
                "physics": text,
                "cv_rms_before": st.cv_before,
                "cv_rms_after": st.cv_after,
            }
        )
    return effects, fitted


def plain(d: dict) -> dict:
    """A dict of numbers, arrays, strings and flags as JSON-ready Python values."""

    def one(v):
        if isinstance(v, (str, bool, np.bool_)) or v is None:
            return v if not isinstance(v, np.bool_) else bool(v)
        if isinstance(v, (list, tuple, np.ndarray)):
            return [one(x) for x in v]
        return int(v) if isinstance(v, (int, np.integer)) else float(v)

    return {k: one(v) for k, v in d.items()}
