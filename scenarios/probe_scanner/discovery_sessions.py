"""Several probe-scanner recordings of one machine, fitted together: the plate turned on the
table between them tells a runout that repeats with the square's sides from the plate's own
form.

On one recording a runout 4, 8, ... times a turn cannot be told from the square plate's form
error (it repeats four times around the plate too). The table's errors stay with the table's
angle, the plate's form turns with the plate: with the plate turned by phi between two
recordings, the form's harmonic h moves by h phi against the runout's, and where that is far
from a whole turn the two are separate unknowns of one fit. The rail and the plate's clamping are
calibrated per recording (block-diagonal scene columns); the plate's form at each such harmonic
is a nuisance shared by the recordings, in the plate's own angle (the table's angle plus the
recording's calibrated rail angle).
"""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy.linalg import block_diag

from calibench.recordings import ScannerRecording
from calibench.recordings.joining import labels_end_to_end, times_end_to_end
from calibench.scenarios.report import BadInput

SYMMETRY = 4  # the square plate's form repeats four times a turn
TOP_HARMONIC = 30  # runouts are searched up to this many times a turn
# a harmonic of the plate's form is told from the table's runout when the recordings' plate
# turns move it by at least this much against the runout (wrapped to +-180 deg)
MIN_FORM_PHASE_DEG = 45.0
# How far one machine's rail (d and dL) may calibrate apart between its recordings: the same
# scanner and plate, turned or repeated, agree within 2 um under any noise of the suites, and
# within 35 um where a fourfold runout and the plate's own form are taken in part by each
# recording's rail (test_a_fourfold_runout_is_told_from_the_plate_s_form_by_turning_the_plate);
# another scanner's rail, drawn over its tolerances (d 7.6-8.4, dL 2.7-3.3 mm), lies further than
# this from the first's in 93 % of draws, and another plate's size moves d by its difference.
SAME_RAIL_MM = 0.1


@dataclasses.dataclass
class Sessions:
    """The recordings end to end, with their per-recording scene models.

    Attributes
    ----------
    rec : ScannerRecording
        (n,) every sample: turns renumbered to stay apart, times run on from one recording to
        the next.
    rec_id : ndarray
        (n,) which recording each sample came from.
    cals : list
        Each recording's calibrated rail and plate (``ScannerCalibration``).
    rho_twin, slope : ndarray
        (n,) the twin's reading and its slope d rho / d theta.
    geo : ndarray
        (n, p) the scene model's free columns: each recording's rail and plate, and the plate's
        form at each harmonic of ``form_harmonics``.
    form_harmonics : tuple of int
        The square's harmonics the plate's turns tell from a runout (searched as runouts).
    """

    rec: ScannerRecording
    rec_id: np.ndarray
    cals: list
    rho_twin: np.ndarray
    slope: np.ndarray
    geo: np.ndarray
    form_harmonics: tuple[int, ...]

    @property
    def turns_deg(self) -> list[float]:
        """Each recording's plate turn against the first's, deg (from the calibrated rails,
        wrapped into the square's quarter turn, +-45 deg)."""
        a0 = self.cals[0].alpha0_rad
        return [float((np.degrees(a0 - c.alpha0_rad) + 45.0) % 90.0 - 45.0) for c in self.cals]


def joined(recs: list[ScannerRecording]) -> tuple[ScannerRecording, np.ndarray]:
    """The recordings end to end (turns renumbered, times running on), and each sample's
    recording id."""
    if len(recs) == 1:
        return recs[0], np.zeros(len(recs[0]), int)
    has = all(r.t_s is not None for r in recs), all(r.temp_c is not None for r in recs)
    rec = ScannerRecording(
        labels_end_to_end([r.turn for r in recs]),
        np.concatenate([r.theta_rad for r in recs]),
        np.concatenate([r.rho_mm for r in recs]),
        times_end_to_end([r.t_s for r in recs if r.t_s is not None]) if has[0] else None,
        np.concatenate([r.temp_c for r in recs]) if has[1] else None,
    )
    return rec, np.repeat(np.arange(len(recs)), [len(r) for r in recs])


def separable(rail_angles: np.ndarray) -> tuple[int, ...]:
    """The multiples of the square's symmetry up to TOP_HARMONIC at which recordings with these
    calibrated rail angles (rad) tell the plate's form from a runout."""
    out = []
    for h in range(SYMMETRY, TOP_HARMONIC + 1, SYMMETRY):
        d = h * (rail_angles[:, None] - rail_angles[None, :])
        wrapped = np.abs((np.degrees(d) + 180.0) % 360.0 - 180.0)
        if wrapped.max(initial=0.0) >= MIN_FORM_PHASE_DEG:
            out.append(h)
    return tuple(out)


def assemble(recs: list[ScannerRecording], config, scene_model) -> Sessions:
    """The recordings' scene models, joined: ``scene_model(rec, config)`` per recording (its
    calibration, twin reading, rail columns, slope), the rail columns block-diagonal, and the
    plate's form columns at the harmonics the recordings' plate turns separate."""
    models = [scene_model(r, config) for r in recs]
    rec, rec_id = joined(recs)
    cals = [m[0] for m in models]
    same_rail(cals)
    geo = block_diag(*[m[2] for m in models]) if len(models) > 1 else models[0][2]
    rails = np.array([c.alpha0_rad for c in cals])
    form = separable(rails) if len(recs) > 1 else ()
    if form:
        plate_angle = rec.theta_rad + rails[rec_id]
        cols = [f(h * plate_angle) for h in form for f in (np.sin, np.cos)]
        geo = np.c_[geo, np.stack(cols, axis=1)]
    return Sessions(
        rec,
        rec_id,
        cals,
        np.concatenate([m[1] for m in models]),
        np.concatenate([m[3] for m in models]),
        geo,
        form,
    )


def same_rail(cals: list) -> None:
    """BadInput unless every recording's rail (d, dL) calibrates to the first's within
    :data:`SAME_RAIL_MM`: a turned plate moves alpha0 and the clamping, never the rail."""
    for k, c in enumerate(cals[1:], 2):
        off = max(abs(c.d_mm - cals[0].d_mm), abs(c.dL_mm - cals[0].dL_mm))
        if off > SAME_RAIL_MM:
            raise BadInput(
                f"recording {k} is not of the same machine and plate as the first: its rail "
                f"calibrates to d = {c.d_mm:.4f}, dL = {c.dL_mm:.4f} mm against "
                f"{cals[0].d_mm:.4f}, {cals[0].dL_mm:.4f} (one scanner's, the plate turned or "
                f"not, agree within {1000 * SAME_RAIL_MM:g} um): another scanner or another "
                "artefact"
            )
