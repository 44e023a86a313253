"""What a geometry-only calibration does on a machine whose twin carries physics: the belt
stage's map, measured through the camera, absorbs the elastic belt's lag exactly as the closed
form (friction over the spans' stiffness, Hooke and Coulomb, derived apart from MuJoCo's tendons)
projected on the map's terms over the stations' visiting order predicts."""

import dataclasses

import numpy as np
import pytest

from calibench.scenarios.belt_stage.scenario import BeltStageConfig, run
from calibench.sim.stage_drive import BeltDrive
from tests.sim.test_stage_drive import closed_form_lag_mm


def _approach(u: np.ndarray) -> np.ndarray:
    """Each station's direction of approach (n,) in the visiting order: the sim homes every axis
    from -1 mm, and a station at the same command keeps the last move's direction."""
    d = np.sign(np.diff(np.r_[-1.0, u]))
    for i in np.flatnonzero(d == 0):
        d[i] = d[i - 1]
    return d


def test_geometry_only_map_absorbs_the_elastic_belt_as_the_closed_form_predicts(tmp_path):
    base = BeltStageConfig()
    belt = BeltDrive(ea_n=35e3, friction_n=4.0)
    elastic = dataclasses.replace(
        base, truth=dataclasses.replace(base.truth, belt_x=belt, belt_y=belt)
    )
    # the same seed: the same noise, so the difference is the belt's alone (common random numbers)
    rigid_r, elastic_r = (run(c, 11, "analytic", tmp_path, False) for c in (base, elastic))
    est = [{p.name: p for p in r.parameters} for r in (rigid_r, elastic_r)]

    xs, ys = np.meshgrid(
        base.stations_x_mm, base.stations_y_mm
    )  # visited row by row, as run() does
    basis = lambda x, y: np.c_[np.ones_like(x), x, y, x * x, x * y, y * y]  # noqa: E731 (error_map's terms)
    for axis, u, travel in (
        ("ex", xs.ravel(), base.geometry.travel_mm[0]),
        ("ey", ys.ravel(), base.geometry.travel_mm[1]),
    ):
        lag = np.array([-d * closed_form_lag_mm(v, travel, belt) for v, d in zip(u, _approach(u))])
        lag -= lag[0]  # travel is measured from the home station
        predicted = np.linalg.lstsq(basis(xs.ravel(), ys.ravel()), lag, rcond=None)[0]
        for k in range(6):
            name = f"{axis}_c{k}"
            got = est[1][name].estimate - est[0][name].estimate
            # 1 % of the shift, or 2 % of the coefficient's own std: what the belt moves besides the
            # map (the board's yaw, the plane of motion) is second order
            assert got == pytest.approx(predicted[k], rel=0.01, abs=0.02 * est[0][name].std), name
    assert (
        abs(est[1]["ex_c1"].estimate - est[1]["ex_c1"].truth) > 5 * est[1]["ex_c1"].std
    )  # the scale is off
    checks = [{c.name: c.value for c in r.checks} for r in (rigid_r, elastic_r)]
    assert (
        checks[1]["check_rms_after_mm"] > 5 * checks[0]["check_rms_after_mm"]
    )  # compensation misses
