"""Do the stated errors of the mechanisms issue 61 added cover their truths?

A Monte-Carlo study like :mod:`.stated_errors`, over the recordings whose truths carry the new
candidates' parameters: an arm's encoder disc slipped at a hard stop (MuJoCo's slip: the
``step``'s size and moment), a stage's scale lagging the logged air (``thermal_expansion``'s
time constant and coefficient), an arm's gear with play (MuJoCo's contacts: ``backlash``'s
play, the truth the play the link shows: the play less the contacts' give and what gravity
takes up, ``simulated.shown_play_urad``; the gear's own play differs from it by up to a tenth,
which no stated error of the noise's covers). Each recording's reading noise is one of
``gaussian`` and the third suite's misspecified kinds in turn (heavy tails, drift, gross
readings, counts). For each parameter found, z = (estimate - truth) / stated std; the coverage
is the share with |z| <= 1.96.

A moment is known to the gap between two readings: the truth is the gap's middle and a found
moment's std at least the gap over sqrt(12), so the moment is covered where its gap is found (a
uniform's 95 % interval is narrower than 1.96 of its std: a found gap covers, whatever its
place in the gap).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from calibench.scenarios.discover.stated_errors import covered, spread
from calibench.scenarios.discover.suite import recorded, searched
from calibench.scenarios.registry import instruments
from calibench.sim.concealed.noise import THIRD_SUITE_NOISES

NOISES = ("gaussian",) + THIRD_SUITE_NOISES
# (concealed kind, the found effect's name, [(truth's parameter, found's)]), each recorded on
# the first instrument whose suites carry the kind (the arm's with its third-suite arm)
MECHANISMS = (
    ("encoder_slip", "step", (("slip_urad", "size_urad"), ("t_s", "at_s"))),
    ("lagged_thermal", "thermal_expansion", (("lag_s", "lag_s"), ("ppm_per_k", "ppm_per_k"))),
    ("gear_play", "backlash", (("shown_urad", "urad"),)),
)


def _label(kind: str) -> str:
    """The suite label of the first instrument whose second or third suite carries ``kind``."""
    for row in instruments():
        if kind in row.simulated:
            return f"{row.name}:{row.simulated_arm}" if row.simulated_arm else row.name
        if kind in row.unwritten:
            return row.name
    raise ValueError(f"no instrument records {kind!r}")


def cases() -> tuple[tuple[str, str, str, tuple], ...]:
    """The study's cases (suite label, kind, the found effect's name, parameter pairs)."""
    return tuple((_label(kind), kind, name, pairs) for kind, name, pairs in MECHANISMS)


SEED0 = 11000  # the study's recordings: apart from the suites' and the first coverage study's


@dataclasses.dataclass
class MechanismCoverage:
    """One parameter's figures over ``recordings`` recordings: ``z`` (k,) its standardised
    errors where the effect was found, ``missed`` the recordings where it was not."""

    kind: str
    parameter: str
    z: np.ndarray
    missed: int
    recordings: int

    @property
    def coverage(self) -> float:
        """Share of |z| <= 1.96 (NaN with none found)."""
        return covered(self.z)


def _where(truth: dict, found: dict) -> bool:
    """Whether a found effect sits where the truth acts: its axis, and its joint where both say."""
    if found["axis"] != truth["axis"] and truth["axis"] not in ("xyz", "legs"):
        return False
    joint = truth["params"].get("joint")
    return joint is None or found["params"].get("joint") == joint


def case_z(label: str, kind: str, name: str, pairs: tuple, seed: int) -> list[float | None]:
    """One recording through discover: per truth and parameter pair, the standardised error of
    the parameter found (None where the effect was not found)."""
    noise = NOISES[seed % len(NOISES)]
    rec, manifest = recorded(label, kind, SEED0 + seed, noise=noise)
    out, _ = searched(label, rec, 0)
    z: list[float | None] = []
    for t in manifest["effects"]:
        # the mechanism with all its parameters (an unlagged expansion is another model)
        hit = [
            f
            for f in out["effects"]
            if f["name"] == name and _where(t, f) and all(q in f["params"] for _, q in pairs)
        ]
        for truth_p, found_p in pairs:
            if not hit or found_p not in hit[0]["stderr"]:
                z.append(None)
                continue
            std = hit[0]["stderr"][found_p]
            z.append((hit[0]["params"][found_p] - t["params"][truth_p]) / max(std, 1e-300))
    return z


def mechanism_coverage(seeds: int, workers: int = 1) -> list[MechanismCoverage]:
    """Every case of :func:`cases` on ``seeds`` recordings (the noises of :data:`NOISES` in
    turn), shared over ``workers`` spawned processes (the same figures, recording for recording,
    whatever the count); one row per case and parameter, in their order."""
    jobs = [
        (label, kind, name, pairs, s) for label, kind, name, pairs in cases() for s in range(seeds)
    ]
    got = spread(case_z, jobs, workers)
    rows, k = [], 0
    for _, kind, _, pairs in cases():
        mine = got[k : k + seeds]
        k += seeds
        for i, (_, found_p) in enumerate(pairs):
            # each recording's truths, the pairs interleaved per truth
            vals = [zs[j] for zs in mine for j in range(i, len(zs), len(pairs))]
            z = np.array([v for v in vals if v is not None], float)
            rows.append(MechanismCoverage(kind, found_p, z, sum(v is None for v in vals), seeds))
    return rows
