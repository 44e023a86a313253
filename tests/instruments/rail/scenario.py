"""Scenario ``rail``: calibrate a one-axis stage's offset, scale and lost motion with a laser
interferometer.

1. The twin (:mod:`.twin`, MuJoCo) runs ``passes`` passes over the stations, each forward then
   backward, every reading approached over a station's step from its side.
2. The interferometer reads the carriage with Gaussian noise (``noise_um``, from the seed).
3. Least squares (:mod:`.estimator`) of offset, scale and lost motion, with their std.
4. The truth is the twin's own, read off its noiseless readings (the lost motion as the mean
   difference of the two directions' readings of one place, the scale from the end stations),
   never 2 F / K: MuJoCo's soft friction and the carriage's stops make the twin's lost motion
   differ from that formula, which the report gives beside it.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np

from calibench.scenarios.report import Check, Parameter, Report
from tests.instruments.rail.estimator import NAMES, fit_rail
from tests.instruments.rail.recording import RailRecording
from tests.instruments.rail.twin import RailTruth, plan, replay

NAME = "rail"
TOL_SIGMA = 4.0  # a parameter is ok within 4 of its std for the stated reading noise
RMS_LIMIT = 1.5  # the residual's RMS within 1.5 times the stated noise: the model is whole
RECORDING, TRUTH = "recording.csv", "recording.truth.json"


@dataclasses.dataclass(frozen=True)
class RailConfig:
    """``[rail]``: the rail as built, the interferometer and the plan.

    Attributes
    ----------
    truth : RailTruth
        The scale error, the carriage's friction and the belt's stiffness.
    noise_um : float
        The interferometer's 1-sigma per reading, um.
    stations : int
        Stations along the travel, equally spaced from 0; at least 3.
    travel_mm : float
        From the first station to the last, mm.
    passes : int
        Passes over the stations, each forward then backward; at least 2 (discover holds out
        whole passes).
    """

    truth: RailTruth = RailTruth()
    noise_um: float = 0.3
    stations: int = 11
    travel_mm: float = 200.0
    passes: int = 3

    def __post_init__(self):
        check_config(self)


def check_config(c: RailConfig) -> None:
    """Each value the rail can take, checked before any simulation (BadInput, one line naming
    the key)."""
    from calibench.scenarios.config import bad

    for key, value, ok, why in (
        ("noise_um", c.noise_um, c.noise_um > 0, "above 0 um"),
        ("stations", c.stations, c.stations >= 3, "at least 3"),
        ("travel_mm", c.travel_mm, 0 < c.travel_mm <= 2000, "above 0 to 2000 mm"),
        ("passes", c.passes, c.passes >= 2, "at least 2"),
        ("truth.friction_n", c.truth.friction_n, 0 <= c.truth.friction_n <= 100, "0 to 100 N"),
        (
            "truth.stiffness_n_per_m",
            c.truth.stiffness_n_per_m,
            1e4 <= c.truth.stiffness_n_per_m <= 1e6,
            "1e4 to 1e6 N/m (the twin's time step holds a stiffer belt badly)",
        ),
        ("truth.scale_ppm", c.truth.scale_ppm, abs(c.truth.scale_ppm) <= 1e4, "within 1e4 ppm"),
    ):
        if not ok:
            raise bad(f"{NAME}.{key}", value, why)


def stations_mm(config: RailConfig) -> np.ndarray:
    """The stations, (stations,) mm from 0 to the travel."""
    return np.linspace(0.0, config.travel_mm, config.stations)


def record(config: RailConfig, seed: int) -> tuple[RailRecording, np.ndarray]:
    """The plan run on the twin of ``config`` and read with the interferometer's noise.

    Returns
    -------
    recording : RailRecording
        (2 passes stations,) readings in time order.
    x_true_mm : (n,) the carriage's noiseless positions at the readings, mm.
    """
    rng = np.random.default_rng(seed)
    s = stations_mm(config)
    x_cmd, dir_x, run_id = plan(s, config.passes)
    x_true = replay(config.truth, x_cmd, dir_x, approach_mm=float(s[1] - s[0]))
    noise = rng.normal(0.0, config.noise_um / 1000.0, len(x_cmd))
    return RailRecording(x_cmd, x_true + noise, dir_x, run_id), x_true


def twin_truth(x_cmd_mm: np.ndarray, x_true_mm: np.ndarray, dir_x: np.ndarray) -> dict:
    """The twin's offset (um), scale (ppm) and lost motion (um) read off its noiseless readings:
    the lost motion the mean of backward minus forward readings of each place, the scale from
    the end stations' midway readings, the offset the midway readings' mean beyond that scale."""
    places = np.unique(x_cmd_mm)
    fw = np.array([x_true_mm[(x_cmd_mm == p) & (dir_x > 0)].mean() for p in places])
    bw = np.array([x_true_mm[(x_cmd_mm == p) & (dir_x < 0)].mean() for p in places])
    mid = (fw + bw) / 2
    scale = (mid[-1] - mid[0]) / (places[-1] - places[0]) - 1.0
    return {
        "offset_um": float(np.mean(mid - places * (1 + scale)) * 1000.0),
        "scale_ppm": float(scale * 1e6),
        "lost_motion_um": float(np.mean(bw - fw) * 1000.0),
    }


def run(config: RailConfig, seed: int, fidelity: str, out_dir: Path | None, rrd: bool) -> Report:
    """Simulate the rail's passes, read them with the interferometer, calibrate offset, scale and
    lost motion, and compare with the twin's own.

    The arguments and the Report: :class:`calibench.scenarios.registry.Scenario`. ``rrd``: the
    rail has no rerun layout, and writes none.
    """
    rec, x_true = record(config, seed)
    fit = fit_rail(rec.x_cmd_mm, rec.x_meas_mm, rec.dir_x)
    truth = twin_truth(rec.x_cmd_mm, x_true, rec.dir_x)
    units = {"offset_um": "um", "scale_ppm": "ppm", "lost_motion_um": "um"}
    report = Report(scenario=NAME, seed=seed, fidelity="analytic")
    report.parameters += [
        Parameter(
            k.rsplit("_", 1)[0],
            units[k],
            truth[k],
            getattr(fit, k),
            fit.std[k],
            TOL_SIGMA * config.noise_um * fit.unit_std[k],
        )
        for k in NAMES
    ]
    t = config.truth
    formula_um = 2 * t.friction_n / t.stiffness_n_per_m * 1e6
    report.checks += [
        Check(
            "residual_rms_um",
            fit.rms_um,
            RMS_LIMIT * config.noise_um,
            note=f"after the fit; limit {RMS_LIMIT:g} times the stated noise",
        ),
        Check(
            "lost_motion_over_2f_k",
            truth["lost_motion_um"] / formula_um if formula_um > 0 else float("nan"),
            None,
            note="the twin's own lost motion over 2 F / K (MuJoCo's soft friction, the stops)",
        ),
    ]
    report.info = {
        "lost_motion_2f_over_k_um": formula_um,
        "friction_n": t.friction_n,
        "stiffness_n_per_m": t.stiffness_n_per_m,
        "readings": len(rec),
    }
    if out_dir is not None:
        write_run_recording(Path(out_dir), rec, truth, config, report.info)
    return report


def write_run_recording(
    out_dir: Path, rec: RailRecording, truth: dict, config: RailConfig, info: dict
) -> None:
    """``out_dir/recording.csv`` (:mod:`.recording`'s format) and beside it what the twin held,
    ``recording.truth.json`` (the effects named as discover names them, the noise, the twin);
    ``info`` (the report's) is told the recording's name."""
    out_dir.mkdir(parents=True, exist_ok=True)
    rec.to_csv(out_dir / RECORDING)
    sealed = {
        "effects": [
            {
                "name": "backlash",
                "axis": "x",
                "params": {"reversal_mm": -truth["lost_motion_um"] / 1000.0},
            },
            {"name": "positioning", "axis": "x", "params": {"scale_ppm": truth["scale_ppm"]}},
        ],
        "noise_um": config.noise_um,
        "recording": RECORDING,
        "rows": len(rec),
        "twin": dataclasses.asdict(config.truth),
    }
    (out_dir / TRUTH).write_text(json.dumps(sealed, indent=1) + "\n")
    info["recording"] = RECORDING


def prior(config: RailConfig, rng: np.random.Generator) -> RailConfig:
    """The study's rail: scale uniform 20-80 ppm, friction 0.5-1.2 N, the belt's stiffness
    within 20 % of the config's."""
    k = config.truth.stiffness_n_per_m
    truth = dataclasses.replace(
        config.truth,
        scale_ppm=float(rng.uniform(20, 80)),
        friction_n=float(rng.uniform(0.5, 1.2)),
        stiffness_n_per_m=float(rng.uniform(0.8, 1.2) * k),
    )
    return dataclasses.replace(config, truth=truth)
