"""Do discover's standard errors cover the truth when the noise is not as assumed?

A Monte-Carlo study over blinded recordings whose concealed effects have a parameter with a
truth (a reversal, a thermal coefficient, a periodic error's amplitude, a runout's, a scale's),
each recording made with one of the reading-noise kinds of ``sim.concealed.noise``. For every
effect found, z = (estimate - truth) / stated std; the coverage is the share with |z| <= 1.96.
Used by benchmarks/discover_coverage.py and its test.
"""

from __future__ import annotations

import concurrent.futures as cf
import dataclasses
import multiprocessing

import numpy as np

from calibench.scenarios.discover.suite import recorded, searched
from calibench.scenarios.registry import instruments
from calibench.sim.concealed.noise import NOISE_KINDS

Z_95 = 1.959963984540054  # the two-sided 95 % normal quantile
# the parameter of each effect whose truth the recordings know
COVERED = {
    "backlash": "reversal_mm",
    "thermal_expansion": "ppm_per_k",
    "periodic": "amplitude_mm",
    "runout": "amplitude_mm",
    "scale": "ppm",
}
# (scenario, concealed kind, recordings per seed asked): each instrument's ``coverage``
CASES = tuple((row.name, *row.coverage) for row in instruments() if row.coverage)
SEED0 = 7000  # the study's recordings: apart from the suites'


@dataclasses.dataclass
class Coverage:
    """One family's figures: ``z`` (k,) the found effects' standardised errors, ``missed`` the
    concealed effects not found, over ``recordings`` recordings."""

    scenario: str
    noise: str
    z: np.ndarray
    missed: int
    recordings: int

    @property
    def coverage(self) -> float:
        """Share of |z| <= 1.96 (NaN with no effect found)."""
        return covered(self.z)


def covered(z: np.ndarray) -> float:
    """Share of the standardised errors ``z`` (k,) with |z| <= 1.96 (NaN with none)."""
    return float(np.mean(np.abs(z) <= Z_95)) if len(z) else float("nan")


def spread(fn, jobs: list[tuple], workers: int) -> list:
    """``fn`` of each job's arguments, in order, over ``workers`` spawned processes (a forked
    child of a process that made a GL context hangs); 1 runs them here."""
    if workers > 1:
        ctx = multiprocessing.get_context("spawn")
        with cf.ProcessPoolExecutor(workers, mp_context=ctx) as pool:
            return list(pool.map(fn, *zip(*jobs)))
    return [fn(*job) for job in jobs]


def case_z(scenario: str, kind: str, noise: str, seed: int) -> tuple[list[float], int]:
    """One recording through discover: the standardised errors of the covered parameters found,
    and how many concealed effects were not found."""
    rec, manifest = recorded(scenario, kind, seed, noise=noise)
    out, _ = searched(scenario, rec, 0)
    z, missed = [], 0
    for t in manifest["effects"]:
        name = COVERED.get(t["name"])
        if name is None:
            continue
        hit = [e for e in out["effects"] if e["name"] == t["name"] and e["axis"] == t["axis"]]
        if not hit or name not in hit[0]["stderr"]:
            missed += 1
            continue
        z.append((hit[0]["params"][name] - t["params"][name]) / hit[0]["stderr"][name])
    return z, missed


def coverage_study(
    seeds: int, noises: tuple[str, ...] = NOISE_KINDS, workers: int = 1
) -> list[Coverage]:
    """Every case of :data:`CASES` under every noise of ``noises``, ``seeds`` recordings each
    (times the case's own factor).

    Parameters
    ----------
    seeds : int
        Recordings per stage family and noise.
    noises : tuple of str
        Reading-noise kinds of ``sim.concealed.noise``.
    workers : int
        Processes the recordings are shared over (spawned: a forked child of a process that made
        a GL context hangs); 1 runs them here. Each recording is seeded, so the figures are the
        same, recording for recording, whatever the count.

    Returns
    -------
    list of Coverage
        One per case and noise, in the order of :data:`CASES` then ``noises``.
    """
    families = [(sc, kind, noise, seeds * f) for sc, kind, f in CASES for noise in noises]
    jobs = [(sc, kind, noise, SEED0 + s) for sc, kind, noise, n in families for s in range(n)]
    got = spread(case_z, jobs, workers)
    out, k = [], 0
    for sc, _, noise, n in families:
        z = [v for zs, _ in got[k : k + n] for v in zs]
        missed = sum(m for _, m in got[k : k + n])
        out.append(Coverage(sc, noise, np.array(z), missed, n))
        k += n
    return out
