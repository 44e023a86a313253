"""The harmonic-search kernel: the period or harmonic that best explains a residual, fast."""

from __future__ import annotations

import functools

import numpy as np
from scipy import optimize

from calibench.estimators.discovery.fit import lstsq


def best_harmonic(
    q: np.ndarray,
    Jt: np.ndarray,
    r: np.ndarray,
    base: np.ndarray,
    harmonics: np.ndarray,
    rows: np.ndarray | None = None,
    n_peaks: int = 3,
    groups: np.ndarray | None = None,
    basis: np.ndarray | None = None,
) -> tuple[float, float]:
    """The harmonic h (cycles per turn) whose angle error a sin(h q) + b cos(h q), seen through
    ``Jt`` (n, 3), best explains ``r`` (3 n,) beside ``base`` (3 n, p), on ``rows`` (3 n,) bool.
    ``groups`` (n,) int: each group of postures (a recording) gets its own a and b, the harmonic
    being shared; what each group's pair explains is summed (the pairs' coupling through
    ``base`` is left out of the sum, as the grid's ranking leaves it out).

    The grid over ``harmonics`` ranks by the residual's projection alone (the columns are not
    orthogonalised against ``base``: cheap, and the ranking barely moves); the best ``n_peaks``
    are then refined by golden section on the exact criterion. Returns h and a rough std (a
    quarter of the grid's spacing). ``basis``: ``base[rows]``'s orthonormal basis, where the
    caller keeps one (every search of a selection round shares its base)."""
    rows = np.ones(len(r), bool) if rows is None else rows
    if basis is not None:
        Q = basis
    elif base.shape[1]:
        Q = np.linalg.qr(base[rows])[0]
    else:
        Q = np.zeros((int(rows.sum()), 0))
    rr = r[rows] - Q @ (Q.T @ r[rows])
    # A column is lever_i sin(h q_p(i)): the kept rows' sums it enters collapse onto the postures
    # (P sums a posture's rows, weighted by their levers), so a harmonic costs one sine per posture
    # rather than per row: S'rr = sin(h q)' P rr, S'S = sin^2(h q)' P lever, Q'S = (P Q)' sin(h q).
    # rr is orthogonal to Q already, so projecting S off Q changes only its Gram matrix, by a'a.
    from scipy import sparse

    lever = Jt.reshape(-1)[rows]
    posture = np.repeat(np.arange(len(q)), 3)[rows]
    P = sparse.csr_matrix((lever, (posture, np.arange(len(lever)))), shape=(len(q), len(lever)))
    w = P @ rr  # (n,)
    l2 = P @ lever  # (n,)
    PQ = np.asarray(P @ Q)  # (n, p)

    def explained_by(w, l2, PQ, part, hs: np.ndarray, project: bool, trig) -> np.ndarray:
        sin, cos, sin2, cos2, sincos = (t[part] for t in trig)
        ss, cc, sc = l2 @ sin2, l2 @ cos2, l2 @ sincos
        sr, cr = w @ sin, w @ cos
        if project and PQ.shape[1]:
            a_s, a_c = PQ.T @ sin, PQ.T @ cos  # (p, m)
            ss, cc, sc = ss - (a_s * a_s).sum(0), cc - (a_c * a_c).sum(0), sc - (a_s * a_c).sum(0)
        det = ss * cc - sc * sc
        ok = det > 1e-9 * np.maximum(ss * cc, 1e-300)
        return np.where(
            ok, (cc * sr * sr - 2 * sc * sr * cr + ss * cr * cr) / np.where(ok, det, 1), 0.0
        )

    # a posture's sums belong to its group alone: each group's share is the sums over its
    # postures (a slice where they are contiguous, as recordings stacked one after another are)
    parts: list[tuple[np.ndarray, np.ndarray, np.ndarray, slice | np.ndarray]] = []
    for g in [None] if groups is None else np.unique(groups):
        if g is None:
            parts.append((w, l2, PQ, slice(None)))
            continue
        idx = np.flatnonzero(groups == g)
        part = slice(idx[0], idx[-1] + 1) if idx[-1] - idx[0] + 1 == len(idx) else idx
        parts.append((w[part], l2[part], PQ[part], part))

    def explained(hs: np.ndarray, project: bool, trig=None) -> np.ndarray:
        if trig is None:  # the groups share the postures' angles: their sines once
            ph = q[:, None] * hs[None, :]  # (n, m)
            sin, cos = np.sin(ph), np.cos(ph)
            trig = sin, cos, sin * sin, cos * cos, sin * cos
        total = sum(explained_by(*p, hs, project, trig) for p in parts)
        assert isinstance(total, np.ndarray)  # parts is never empty: never the int start 0
        return total

    def exact(hs: np.ndarray) -> np.ndarray:
        return explained(hs, True)

    grid = np.asarray(harmonics, float)
    score = explained(
        grid, False, _grid_trig(np.ascontiguousarray(q, float).tobytes(), grid.tobytes())
    )
    peaks = [
        k
        for k in range(len(grid))
        if score[k] >= score[max(k - 1, 0)] and score[k] >= score[min(k + 1, len(grid) - 1)]
    ]
    peaks = sorted(peaks, key=lambda k: -score[k])[:n_peaks] or [int(np.argmax(score))]
    step = float(np.median(np.diff(grid))) if len(grid) > 1 else 0.1
    g = (np.sqrt(5) - 1) / 2
    best = (-np.inf, grid[peaks[0]])
    for k in peaks:
        # golden section: each step keeps one inner point and its value, and evaluates one new
        lo, hi = grid[k] - step, grid[k] + step
        a, b = hi - g * (hi - lo), lo + g * (hi - lo)
        ea, eb = exact(np.array([a, b]))
        for _ in range(25):
            if ea > eb:
                hi, b, eb = b, a, ea
                a = hi - g * (hi - lo)
                ea = float(exact(np.array([a]))[0])
            else:
                lo, a, ea = a, b, eb
                b = lo + g * (hi - lo)
                eb = float(exact(np.array([b]))[0])
        h = 0.5 * (lo + hi)
        e = float(exact(np.array([h]))[0])
        if e > best[0]:
            best = (e, h)
    return float(best[1]), step / 4


@functools.lru_cache(maxsize=8)
def _grid_trig(q_bytes: bytes, grid_bytes: bytes) -> tuple[np.ndarray, ...]:
    """sin, cos, sin^2, cos^2 and sin cos of h q for every angle and grid harmonic, (n, m) each:
    the same for every fold and every round of a discovery (only the rows' weights change), so
    computed once per joint's angles and grid."""
    ph = np.frombuffer(q_bytes)[:, None] * np.frombuffer(grid_bytes)[None, :]
    sin, cos = np.sin(ph), np.cos(ph)
    out = (sin, cos, sin * sin, cos * cos, sin * cos)
    for a in out:
        a.flags.writeable = False
    return out


def harmonic_grid(q_joint: np.ndarray, top: float = 60.0) -> np.ndarray:
    """Harmonics 2..top cycles per turn, spaced to resolve the joint's span of angles (a quarter
    of a cycle over the span)."""
    span = max(float(np.ptp(q_joint)), 1e-3)
    step = min(0.25, 0.25 * 2 * np.pi / span)
    return np.arange(1.75, top + 1e-9, step)


def best_period(
    u: np.ndarray, r: np.ndarray, base: np.ndarray, periods: np.ndarray
) -> tuple[float, float]:
    """The period (mm) whose sinusoid in ``u`` (n,) best explains ``r`` (n,) beside the columns
    ``base`` (n, p), and the fraction of r's variance it explains: a least-squares periodogram
    (Lomb-Scargle with the baseline floating), vectorised over ``periods`` (m,)."""
    Q, _ = np.linalg.qr(base)
    r_perp = r - Q @ (Q.T @ r)
    ph = 2 * np.pi * u[:, None] / periods[None, :]  # (n, m)
    S, C = np.sin(ph), np.cos(ph)
    S -= Q @ (Q.T @ S)
    C -= Q @ (Q.T @ C)
    ss, cc, sc = (S * S).sum(0), (C * C).sum(0), (S * C).sum(0)
    sr, cr = S.T @ r_perp, C.T @ r_perp
    det = ss * cc - sc * sc
    ok = det > 1e-9 * np.maximum(ss * cc, 1e-300)
    explained = np.where(
        ok, (cc * sr * sr - 2 * sc * sr * cr + ss * cr * cr) / np.where(ok, det, 1), 0.0
    )
    k = int(np.argmax(explained))
    return float(periods[k]), float(explained[k] / max(r_perp @ r_perp, 1e-300))


def grid_rel(periods: np.ndarray, P0: float) -> float:
    """Half-width of the search around a grid period: 1.5 grid steps, relative."""
    k = int(np.argmin(np.abs(periods - P0)))
    step = np.abs(periods[min(k + 1, len(periods) - 1)] - periods[max(k - 1, 0)]) / 2
    return float(max(1.5 * step / P0, 1e-3))


def refine_period(u, r, base, P0, rel: float = 0.03) -> tuple[float, float]:
    """The period minimising the residual (variable projection: amplitudes solved inside),
    within ``rel`` of P0; its std from the curvature of the sum of squares."""

    def sse(P):
        X = np.c_[base, np.sin(2 * np.pi * u / P), np.cos(2 * np.pi * u / P)]
        e = r - X @ lstsq(X, r)
        return float(e @ e)

    sol = optimize.minimize_scalar(
        sse, bounds=(P0 * (1 - rel), P0 * (1 + rel)), method="bounded", options={"xatol": P0 * 1e-7}
    )
    P, f0 = float(sol.x), float(sol.fun)
    h = P * 1e-4
    curv = (sse(P + h) - 2 * f0 + sse(P - h)) / (h * h)
    s2 = f0 / max(len(r) - base.shape[1] - 3, 1)
    return P, float(np.sqrt(2 * s2 / curv)) if curv > 0 else float("nan")
