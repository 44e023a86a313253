"""The arm's discovery over several sessions (recordings, each its own frame and power-up): a
harmonic's phase per session kept only where it earns its coefficients, the recordings refused
as another arm's when their geometries differ, and each effect said to belong to the machine
(it carries to a session held out whole) or to the sessions it was found in.
"""

from __future__ import annotations

import dataclasses
from typing import cast

import numpy as np

from calibench.estimators.discovery.effect import Effect
from calibench.estimators.discovery.fit import Signal, cv_residuals, rms
from calibench.estimators.discovery.select import Discovery, Step, carry_to_new_sessions
from calibench.scenarios.discover.same_machine import SAME_ARM_MM, own_geometry_rms, refuse_another

REGISTER_FRACTION = 0.2  # of a session held out whole: the rows its own terms are fitted on


def register_rows(rec_id: np.ndarray) -> np.ndarray:
    """(n,) bool: a fixed draw of :data:`REGISTER_FRACTION` of each session's rows (fit's
    --leave-one-out registers a new session on as many). ``rec_id`` (n,): each row's session."""
    out = np.zeros(len(rec_id), bool)
    rng = np.random.default_rng(0)
    for k in np.unique(rec_id):
        rows = rng.permutation(np.flatnonzero(rec_id == k))
        out[rows[: max(int(round(REGISTER_FRACTION * len(rows))), 3)]] = True
    return out


def shared_unless_sessions_differ(
    sig: Signal, found: Discovery, terms: list, drivers: dict, fold: np.ndarray, floor: float
) -> None:
    """A harmonic with a phase per recording stays so only if it beats the same harmonic with
    one phase for all by ``floor`` of the held-out RMS (the extra coefficients otherwise fit
    noise): replaced in ``terms`` and in its step otherwise."""
    for i, t in enumerate(terms):
        if not getattr(t, "per_recording", False):
            continue
        shared = dataclasses.replace(t, per_recording=False)
        cv_per = rms(cv_residuals(sig, terms, drivers, fold, {}))
        cv_shared = rms(cv_residuals(sig, terms[:i] + [shared] + terms[i + 1 :], drivers, fold, {}))
        if cv_per > (1 - floor) * cv_shared:
            for k, st in enumerate(found.steps):
                if st.term is t:
                    # the last step's figure is the final one: both now the shared term's
                    last = k == len(found.steps) - 1
                    found.steps[k] = dataclasses.replace(
                        st, term=shared, cv_after=cv_shared if last else st.cv_after
                    )
            terms[i] = shared
            found.cv_final = cv_shared


def carried_to_sessions(
    sig: Signal,
    found: Discovery,
    terms: list,
    drivers: dict,
    fold: np.ndarray,
    rec_id: np.ndarray,
    geometry: Effect | None,
) -> dict[int, dict]:
    """Several sessions: refused as another arm's when the sessions' own geometries differ
    beyond :data:`SAME_ARM_MM`, then each accepted effect held out with whole sessions
    (:func:`~calibench.estimators.discovery.select.carry_to_new_sessions`; what does not carry
    goes, in place).

    Returns
    -------
    {id(term): the new sessions' RMS without and with it}
    """
    if geometry is not None:
        moved, left = own_geometry_rms(sig, terms, geometry, drivers, rec_id)
        refuse_another(moved, left, SAME_ARM_MM, "arm", "link errors")
    return carry_to_new_sessions(sig, found, terms, drivers, fold, rec_id, register_rows(rec_id))


def say_belonging(effects: list[dict], steps: list[Step], carry: dict[int, dict]) -> None:
    """Each described effect (in the order of ``steps``) that was held out with whole sessions
    says whether it belongs to the machine or the session, the new sessions' RMS, and what a new
    session refits of it. In place."""
    for st, e in zip(steps, effects):
        if id(st.term) in carry:
            e["belongs"] = "session" if getattr(st.term, "per_recording", False) else "machine"
            e["new_session_rms"] = carry[id(st.term)]
            if getattr(st.term, "session_refit", False):
                what = (
                    "values" if cast(Effect, st.term).name == "nonsmooth" else "amplitude and phase"
                )
                e["new_session"] = f"its {what} refitted on the session's registration rows"
