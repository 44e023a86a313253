"""``nonsmooth``: structure no candidate explains, located and modelled as a correction table."""

from __future__ import annotations

import dataclasses

import numpy as np

from calibench.estimators.discovery.effect import Drivers
from calibench.estimators.discovery.fit import Signal, cv_residuals, fit_terms, rms
from calibench.estimators.discovery.locate import where_text
from calibench.estimators.discovery.noise import Noise
from calibench.estimators.discovery.select import FLOOR

NONSMOOTH_Z = 4.5  # a station's mean residual this many of its std from zero is structure


@dataclasses.dataclass(frozen=True)
class StationTable:
    """``nonsmooth``: a free correction at each of the flagged stations (a lookup table)."""

    axis: str
    station: np.ndarray  # (m,) station id of each row, -1 outside the region
    n: int
    where: str
    name: str = "nonsmooth"

    @property
    def key(self) -> str:
        """The table's name and axis."""
        return f"nonsmooth:{self.axis}"

    def columns(self, drivers=None) -> np.ndarray:
        """One indicator column per station (the residual no law explains), (n, n_stations)."""
        X = np.zeros((len(self.station), self.n))
        ok = self.station >= 0
        X[np.flatnonzero(ok), self.station[ok]] = 1.0
        return X

    def describe(self, coef, cov):
        """Where the table's largest values sit, in words."""
        k = int(np.argmax(np.abs(coef)))
        return (
            {"where": self.where, "peak_mm": float(coef[k])},
            {"peak_mm": float(np.sqrt(max(cov[k, k], 0)))},
            f"a local error of the {self.axis.upper()} reading {self.where} that no candidate "
            "effect has "
            f"(a damaged or dirty guide, a bump in a rail): modelled as a correction table there",
        )


def find_nonsmooth(
    sig: Signal,
    terms: list,
    drivers: Drivers,
    station: np.ndarray,
    positions: np.ndarray,
    noise: Noise,
    fold: np.ndarray,
    floor: float = FLOOR,
) -> StationTable | None:
    """Stations whose mean residual (over passes) stands out of the repeatability, grown to their
    neighbours; kept only if a correction table there helps held out. ``station`` (m,) ids per
    row, ``positions`` (n_stations, 2) their (x, y)."""
    if noise.sigma_mm is None:
        return None
    _, _, _, res = fit_terms(sig, terms, drivers, {}, None)
    ids, inv, counts = np.unique(station, return_inverse=True, return_counts=True)
    means = np.bincount(inv, weights=res) / counts
    z = means / (noise.sigma_mm * noise.inflation / np.sqrt(counts))
    hot = np.abs(z) > NONSMOOTH_Z
    if hot.sum() < 2:
        return None
    # grow to the neighbours that lean the same way (|z| > 2), within 3 station spacings
    pos = positions[ids]
    core = pos[hot]
    near = np.min(np.linalg.norm(pos[:, None] - core[None], axis=2), axis=1)
    spacing = np.median(np.sort(np.linalg.norm(pos[:, None] - pos[None], axis=2), axis=1)[:, 1])
    region = hot | ((np.abs(z) > 2) & (near <= 3 * spacing))
    table_id = -np.ones(len(ids), int)
    table_id[region] = np.arange(region.sum())
    reg = pos[region]
    peak = pos[np.argmax(np.abs(z))]
    where = (
        f"at {where_text(reg[:, 0], 'x')}, {where_text(reg[:, 1], 'y')} "
        f"(largest at x = {peak[0]:.0f} mm, y = {peak[1]:.0f} mm)"
    )
    table = StationTable(axis=sig.axis, station=table_id[inv], n=int(region.sum()), where=where)
    cache: dict[str, np.ndarray] = {}
    before = rms(cv_residuals(sig, terms, drivers, fold, cache))
    after = rms(cv_residuals(sig, terms + [table], drivers, fold, cache))
    return table if after < (1 - floor) * before else None
