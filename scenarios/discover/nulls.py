"""The null calibration of discover's acceptance floor: on how many fresh null recordings
(nothing concealed) discover claims an effect, at each floor (the README's discover-nulls table;
benchmarks/discover.py runs the same recordings one after the other)."""

from __future__ import annotations

import concurrent.futures as cf
import multiprocessing
import os

from calibench.scenarios.discover.suite import null_claims


def null_claim_rates(
    floors_by_scenario: dict[str, tuple[float, ...]],
    nulls: int,
    executor: cf.Executor | None = None,
) -> dict[str, dict[float, float]]:
    """The false-claim rate of discover on ``nulls`` fresh null recordings per scenario.

    Recording k of a scenario is the suite's null with seed ``NULL_SEED + k``
    (scenarios.discover.suite's ``null_claims``); each is discovered once per floor, any effect
    claimed (the twin's own ``geometry`` aside) counts.

    Parameters
    ----------
    floors_by_scenario : dict
        {scenario (or ``NAME:ARM``, with a further arm): the floors to try (fractions of the
        held-out RMS)}, in the order the result keeps.
    nulls : int
        Null recordings per scenario.
    executor : concurrent.futures.Executor, optional
        Where the recordings run, each independent and seeded; None: a spawn process pool over
        all cores (MuJoCo renders hang in a forked child).

    Returns
    -------
    dict
        {scenario: {floor: share of the recordings with a claim}}.
    """
    jobs = {(sc, k): floors for sc, floors in floors_by_scenario.items() for k in range(nulls)}
    pool = executor or cf.ProcessPoolExecutor(
        os.cpu_count() or 1, mp_context=multiprocessing.get_context("spawn")
    )
    try:
        futures = {job: pool.submit(null_claims, *job, floors) for job, floors in jobs.items()}
        got = {job: f.result() for job, f in futures.items()}
    finally:
        if executor is None:
            pool.shutdown()
    count: dict[str, dict[float, int]] = {}
    for (sc, k), floors in jobs.items():
        claims = count.setdefault(sc, dict.fromkeys(floors, 0))
        for f, claimed in zip(floors, got[sc, k]):
            claims[f] += claimed
    return {sc: {f: c / nulls for f, c in claims.items()} for sc, claims in count.items()}
