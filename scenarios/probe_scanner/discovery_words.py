"""What the scanner's discovery says in words: which sessions the plate's turns separate, the
candidates that look alike on this plate (with the experiment that tells them apart), and where
on a turn the residual lives."""

from __future__ import annotations

import numpy as np

from calibench.estimators.discovery.confounds import find_confounds
from calibench.estimators.discovery.effect import Effect
from calibench.estimators.discovery.fit import lstsq
from calibench.estimators.discovery.locate import Driver, follows
from calibench.estimators.discovery.probe_scanner import AXIS, Runout, TableEccentricity

BIN_DEG = 1.0  # the nonsmooth table's bands of the table's angle
# located on the turn: the bands whose median residual (smoothed over LOCAL_SMOOTH bands) reaches
# half the largest, named when they cover at most LOCAL_SPAN of the turn
LOCAL_SMOOTH, LOCAL_SPAN = 5, 1 / 3


def runs_said(bands: np.ndarray) -> list[str]:
    """Consecutive bands as "lo-hi" in degrees."""
    out, start = [], bands[0]
    for a, b in zip(bands, list(bands[1:]) + [None]):
        if b is None or b != a + 1:
            out.append(f"{start * BIN_DEG:g}-{(a + 1) * BIN_DEG:g}")
            if b is not None:
                start = b
    return out


TURN_THE_PLATE = (
    "turn the plate on the table by 45 deg and record again (a fourfold form then turns by half "
    "its period against the table); `calibench discover probe-scanner first.csv turned.csv` "
    "fits the two together and tells the table's runout from the plate's form at each harmonic "
    "the turn moves"
)
# An encoder's eccentricity is an angle error. Its effect on the reading is what a shift of the
# artefact's centre does along its wall, and a once-per-turn radial motion is what a shift does
# across it: with the artefact's centre calibrated in every recording (it must be), no artefact
# and no turn of it tells the two apart (a turned plate was tried: 99.8 % confounded as
# before). Only an angle reference sees the eccentricity.
SEPARATE_BY_AN_ANGLE_REFERENCE = (
    "compare the table's angle with an angle reference (a polygon and an autocollimator), or "
    "read the encoder with a second head opposite the first (their mean cancels an "
    "eccentricity); a once-per-turn radial motion is the artefact's centring on any artefact "
    "and is calibrated with it"
)


def sessions_said(sessions) -> dict:
    """discovery.json's ``recordings`` where several were fitted together: each one's samples,
    rail and plate turn, and the square's harmonics their turns told apart from a runout."""
    if len(sessions.cals) == 1:
        return {}
    return {
        "recordings": [
            {
                "samples": int(np.sum(sessions.rec_id == k)),
                "rail": {"d_mm": c.d_mm, "dL_mm": c.dL_mm, "alpha0_rad": c.alpha0_rad},
                "plate_turn_deg": turn,
            }
            for k, (c, turn) in enumerate(zip(sessions.cals, sessions.turns_deg))
        ],
        "form_told_apart": list(sessions.form_harmonics),
    }


def look_alikes(sig, terms: list, drivers) -> list[dict]:
    """Accepted effects another candidate would reproduce almost wholly on this artefact (an
    encoder's eccentricity and a once-per-turn runout on the square plate): said as confounded,
    with the experiment that separates them, not left as a confident name."""
    out = []
    pairs: tuple[tuple[str, Effect, str], ...]
    pairs = (("runout", TableEccentricity(), "encoder_eccentricity"),)
    pairs += (("encoder_eccentricity", Runout(harmonic=1), "runout (once per turn)"),)
    for name, other, other_name in pairs:
        accepted = [t for t in terms if t.name == name and getattr(t, "harmonic", 1) == 1]
        if not accepted or any(
            t.name == other.name and getattr(t, "harmonic", 1) == 1 for t in terms
        ):
            continue
        for f in find_confounds({AXIS: sig}, {AXIS: terms}, [other], drivers):
            frac = f.fraction
            out.append(
                {
                    "effect": name,
                    "axis": AXIS,
                    "with": other_name,
                    "why": f"on this artefact the calibrated rail and the {name.replace('_', ' ')} "
                    f"found reproduce {100 * frac:.0f} % of an {other_name.replace('_', ' ')}: "
                    "the recording cannot say which it is",
                    "experiment": SEPARATE_BY_AN_ANGLE_REFERENCE,
                }
            )
    return out


def where_on_turn(r: np.ndarray, theta_deg: np.ndarray) -> str:
    """Where on the turn the residual ``r`` (n,) lives: the bands of the angle whose median
    (smoothed over LOCAL_SMOOTH bands) reaches half the largest, said as angles when they cover
    at most LOCAL_SPAN of the turn in at most three runs, else "over the whole turn" (a runout,
    an eccentricity: a sinusoid is above half its peak over two thirds of the turn)."""
    n_bins = int(round(360 / BIN_DEG))
    band = np.floor(np.asarray(theta_deg, float) / BIN_DEG).astype(int) % n_bins
    # medians, not means: one gross reading would otherwise make its band stand out
    order = np.lexsort((r, band))
    counts = np.bincount(band, minlength=n_bins)
    start = np.r_[0, np.cumsum(counts)[:-1]]
    full = counts > 0
    mid = np.zeros(n_bins)
    lo, hi = start + (counts - 1) // 2, start + counts // 2
    mid[full] = 0.5 * (r[order][lo[full]] + r[order][hi[full]])
    pad = np.r_[mid[-LOCAL_SMOOTH:], mid, mid[:LOCAL_SMOOTH]]
    smooth = np.abs(np.convolve(pad, np.ones(LOCAL_SMOOTH) / LOCAL_SMOOTH, "same"))
    smooth = smooth[LOCAL_SMOOTH:-LOCAL_SMOOTH]
    bands = np.flatnonzero(smooth >= 0.5 * smooth.max())
    runs = runs_said(bands) if len(bands) else []
    if not runs or len(bands) > LOCAL_SPAN * n_bins or len(runs) > 3:
        return "over the whole turn"
    return f"at table angles {', '.join(runs)} deg"


def locate_scanner(sig, drivers, rec, seed) -> list[dict]:
    """The residual after the scene model against the angle (per-turn cyclic shifts as the
    null) and against time and temperature (whole turns permuted)."""
    rng = np.random.default_rng(seed)
    r = sig.r - sig.base @ lstsq(sig.base, sig.r)
    tested = [
        Driver("theta_deg", np.degrees(np.mod(rec.theta_rad, 2 * np.pi)), "shift"),
        Driver("t_s", rec.t_s, "passes"),
        Driver("temp_c", rec.temp_c, "passes"),
    ]
    out = [
        {
            "signal": sig.name,
            "driver": f.name,
            "score": f.score,
            "p_value": f.p,
            "where": where_on_turn(r, f.values) if f.name == "theta_deg" else f"follows {f.name}",
        }
        for f in follows(r, tested, rec.turn, rng, n_perm=99)
    ]
    return sorted(out, key=lambda d: -d["score"])
