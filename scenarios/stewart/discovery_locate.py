"""Where a Stewart platform's legs disagree with the twin: each leg's residual after the hinge
geometry against its own length, direction of approach and axial force, and against time and
temperature, with permutation tests (``located`` in discovery.json)."""

from __future__ import annotations

import numpy as np

from calibench.estimators.discovery.effect import Drivers
from calibench.estimators.discovery.locate import Driver, follows


def locate(
    res: np.ndarray, drivers: Drivers, seed: int, n_perm: int = 499, alpha: float = 0.002
) -> list[dict]:
    """Which leg disagrees with the twin, and where: each leg's residual after the hinge geometry
    (res (n_poses, 6) mm) against its own length, direction of approach and axial force, and
    against time and temperature. The null: for time and temperature the poses' order permuted;
    for the others the residuals shifted cyclically in time, which keeps a drift's structure.
    Thirty tests at once, so a finding needs no permuted score above its own in ``n_perm``
    (p <= 0.002: about 6 % for a null recording's thirty)."""
    rng = np.random.default_rng(seed)
    n = len(res)
    zero = np.zeros(n)
    out = []
    for i in range(6):
        r = res[:, i]
        tested = [
            Driver("length", drivers["L"][:, i], "along"),
            Driver("direction", None if drivers["dir"] is None else drivers["dir"][:, i]),
            Driver("axial_force", drivers["force"][:, i]),
            # the poses come in random order: time itself is what is tested
            Driver("temp_c", drivers["temp_c"], "shuffle"),
            Driver("t_s", drivers["t_s"], "shuffle"),
        ]
        for f in follows(r, tested, zero, rng, alpha, 0.05, n_perm):
            out.append(
                {
                    "signal": f"leg {i + 1} reading - twin (after geometry)",
                    "driver": f.name,
                    "leg": i + 1,
                    "score": f.score,
                    "p_value": f.p,
                    "where": _where(r, f.values, f.name, i + 1),
                }
            )
    return sorted(out, key=lambda d: -d["score"])


def _where(r, v, name, leg) -> str:
    if name == "direction":
        return (
            f"leg {leg}: extending minus retracting "
            f"{1000 * (r[v > 0].mean() - r[v < 0].mean()):+.1f} um at the same poses"
        )
    if name in ("temp_c", "t_s"):
        slope = np.polyfit(v, r, 1)[0]
        unit = "K" if name == "temp_c" else "h"
        return (
            f"leg {leg} follows {name}: "
            f"{1000 * slope * (1 if name == 'temp_c' else 3600):+.2f} um per {unit}"
        )
    if name == "axial_force":
        return (
            f"leg {leg} reads more the more it carries: {1000 * np.polyfit(v, r, 1)[0]:+.4f} um "
            "per N of axial load, beyond what the hinge geometry absorbed"
        )
    edges = np.quantile(v, np.linspace(0, 1, 9))
    idx = np.clip(np.searchsorted(edges, v, side="right") - 1, 0, 7)
    amp = np.array([np.ptp(r[idx == k]) if np.sum(idx == k) > 1 else 0.0 for k in range(8)])
    k = int(np.argmax(amp))
    return (
        f"leg {leg} along its length {v.min():.0f}-{v.max():.0f} mm, widest at {edges[k]:.0f}-"
        f"{edges[k + 1]:.0f} mm ({1000 * amp[k]:.1f} um peak to peak)"
    )
