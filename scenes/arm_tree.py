"""A branched arm's description (docs/formats.md, "Arm descriptions"): each joint's parent, the
joints that follow others without an encoder of their own, and several tools. Read from an
ARM.toml's ``[[joint]]`` tables (``parent``, ``follows``) and its ``[[tool]]`` tables; every
defect is one :class:`~calibench.scenes.arm_cmm.ArmFileError` line naming the joint or tool.

A serial arm is the tree's special case and reads as it always did: no ``parent`` gives each
joint the previous one, one tool sits on the last joint, and the description then holds None in
these fields (the same description, and the same twin, as before trees).
"""

from __future__ import annotations

import math

from calibench.errors import BadInput

MAX_COEFFICIENT = 1e3  # a follower's coefficient beyond this is a wrong unit, not a linkage


def _whole(v) -> bool:
    return isinstance(v, int) and not isinstance(v, bool)


def parents(joints: list[dict], where: str, error: type[BadInput]) -> tuple | None:
    """Each joint's parent (N,): 0 the base, k joint k (1-based), the previous joint where not
    given; None for a serial arm (every joint after the previous one).

    Raises ``error`` for a parent that is no joint, the joint itself, a cycle, or a parent that
    comes after its child (joints are listed base outward)."""
    N = len(joints)
    out = []
    for i, j in enumerate(joints, 1):
        p = j.get("parent", i - 1)
        if not _whole(p):
            raise error(
                f"{where}: joint {i}: parent must be a whole number (0 the base, k joint k), "
                f"not {p!r}"
            )
        if not 0 <= p <= N:
            raise error(
                f"{where}: joint {i}: parent = {p}: no such joint (the arm has {N} joints; 0 is "
                "the base)"
            )
        if p == i:
            raise error(f"{where}: joint {i}: parent = {i} is the joint itself: a cycle")
        out.append(p)
    for i in range(1, N + 1):  # a cycle: parents that never reach the base
        seen, k = [i], out[i - 1]
        while k != 0 and k not in seen:
            seen.append(k)
            k = out[k - 1]
        if k == i:
            loop = " -> ".join(str(s) for s in seen + [i])
            raise error(
                f"{where}: joints {loop} form a cycle: each joint's parents must lead to the "
                "base (0)"
            )
    for i, p in enumerate(out, 1):
        if p > i:
            raise error(
                f"{where}: joint {i}: parent = {p} comes after it: list the joints base outward, "
                "each after its parent"
            )
    return None if out == list(range(N)) else tuple(out)


def follows(joints: list[dict], where: str, error: type[BadInput]) -> tuple | None:
    """The readings-to-angles matrix (N, N) of an arm whose joints may follow others (``follows
    = [[i, a], [j, b]]``: the joint's angle a q_i + b q_j, no encoder of its own; its row those
    coefficients, its column zero), or None where no joint does.

    Raises ``error`` for a list that is no list of [joint, coefficient] pairs, a joint that
    follows itself, no joint, another follower, or one joint twice."""
    N = len(joints)
    rows = [[float(i == k) for k in range(N)] for i in range(N)]
    said = {i: j["follows"] for i, j in enumerate(joints, 1) if "follows" in j}
    for i, pairs in said.items():
        w = f"{where}: joint {i}: follows"
        if (
            not isinstance(pairs, list)
            or not pairs
            or not all(isinstance(p, list) and len(p) == 2 for p in pairs)
        ):
            raise error(
                f"{w} must be a list of [joint, coefficient] pairs (its angle their sum, e.g. "
                f"[[1, 0.5], [2, 0.5]]), not {pairs!r}"
            )
        row = [0.0] * N
        for k, a in pairs:
            if not _whole(k):
                raise error(f"{w}: {k!r} is not a joint's number (1..{N})")
            if k == i:
                raise error(f"{w} joint {i}, itself: a joint follows others")
            if not 1 <= k <= N:
                raise error(f"{w} joint {k}: no such joint (the arm has {N} joints)")
            if k in said:
                raise error(
                    f"{w} joint {k}, which follows others itself: a joint follows joints that "
                    "have encoders"
                )
            if isinstance(a, bool) or not isinstance(a, (int, float)) or not math.isfinite(a):
                raise error(f"{w}: joint {k}'s coefficient must be a finite number, not {a!r}")
            if not 0 < abs(a) <= MAX_COEFFICIENT:
                raise error(
                    f"{w}: joint {k}'s coefficient {a} is out of range (0 < |a| <= "
                    f"{MAX_COEFFICIENT:g})"
                )
            if row[k - 1]:
                raise error(f"{w} joint {k} twice: give each joint once")
            row[k - 1] = float(a)
        rows[i - 1] = row
    return tuple(tuple(r) for r in rows) if said else None


def tools(
    table, where: str, N: int, error: type[BadInput], number, vector
) -> list[tuple[tuple, int, float]]:
    """The tools: ``[tool]`` (one, on the last joint) or ``[[tool]]`` tables, each
    (offset (3,) mm, its joint (1-based), mass kg). ``number`` and ``vector``: the description's
    checked readers of a number and of a list."""
    if isinstance(table, dict):
        tables, many = [table], False
    elif isinstance(table, list) and table and all(isinstance(t, dict) for t in table):
        tables, many = table, True
    else:
        raise error(f"{where}: [tool] must be a table, or [[tool]] one table per tool")
    out = []
    for k, t in enumerate(tables, 1):
        w = f"{where}: [tool]" if not many else f"{where}: tool {k}"
        known = {"offset_mm", "mass_kg"} | ({"parent"} if many else set())
        extra = set(t) - known
        if extra:
            raise error(
                f"{w}: unknown field(s) {', '.join(sorted(extra))} (known: "
                f"{', '.join(sorted(known))})"
            )
        at = t.get("parent", N)
        if not _whole(at) or not 1 <= at <= N:
            raise error(
                f"{w}: parent = {at!r}: no such joint (the joint whose link carries the tool, "
                f"1..{N})"
            )
        offset = vector(t, "offset_mm", w, 3, default=(0.0, 0.0, 0.0), bound=1e5)
        out.append((offset, at, number(t, "mass_kg", w, default=0.0, lo=0.0, hi=1e4)))
    return out
