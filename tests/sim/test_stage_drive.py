"""The stage drives' physics: the elastic belt's rest point from MuJoCo against a closed form
derived separately (two springs in parallel, Hooke and Coulomb), stiction, and the drive errors."""

import numpy as np
import pytest

from calibench.sim.stage_drive import BeltDrive, DriveErrors, ElasticBelt


def closed_form_lag_mm(u_mm: float, travel_mm: float, drive: BeltDrive) -> float:
    """Friction over the two spans' stiffness EA / L: the tight span from the drive pulley to
    the clamp, the return span round the idler (its two tangent runs and the 2r between)."""
    a, r = drive.overhang_mm, drive.pulley_radius_mm
    tight = u_mm + a
    back = (travel_mm + a - u_mm) + 2 * r + (travel_mm + 2 * a)
    k_n_per_mm = drive.ea_n * (1 / tight + 1 / back)
    return drive.friction_n / k_n_per_mm


@pytest.mark.parametrize("ea, friction", [(40e3, 3.0), (25e3, 5.0)])
def test_elastic_belt_rests_short_of_its_command_by_friction_over_stiffness(ea, friction):
    drive = BeltDrive(ea_n=ea, friction_n=friction)
    belt = ElasticBelt(1000.0, drive)
    belt.move(-1.0)
    for target, direction in (
        (100.0, 1),
        (250.0, 1),
        (500.0, 1),
        (400.0, -1),
        (120.0, -1),
        (600.0, 1),
    ):
        lag = belt.move(target) - target
        # 1e-6 mm: the rest point to a nanometre (the settling loop stops at 1e-12 m/s)
        assert lag == pytest.approx(
            -direction * closed_form_lag_mm(target, 1000.0, drive), abs=1e-6
        )


def test_lost_motion_grows_along_the_travel():
    drive = BeltDrive(ea_n=40e3, friction_n=3.0)
    rev = []
    for at in (50.0, 500.0, 900.0):
        belt = ElasticBelt(1000.0, drive)
        belt.move(at - 5)
        forward = belt.move(at)
        belt.move(at + 5)
        rev.append(forward - belt.move(at))
    assert rev[0] < 0 and rev[2] < rev[1] < rev[0]  # short of the command, more so further out
    assert rev[2] / rev[0] > 5


def test_a_move_within_the_dead_band_does_not_move_the_carriage():
    drive = BeltDrive(ea_n=40e3, friction_n=3.0)
    belt = ElasticBelt(1000.0, drive)
    belt.move(200.0)
    rest = belt.u_mm
    lag = closed_form_lag_mm(200.0, 1000.0, drive)
    assert (
        belt.move(200.0 - 1.5 * lag) == rest
    )  # back by less than twice the lag: friction holds it
    assert belt.move(200.0 - 3 * lag) < rest


def test_drive_errors_are_the_written_physics():
    d = DriveErrors(
        reversal_at_home_um=-4.0,
        reversal_growth_um_per_m=-60.0,
        periodic_um=5.0,
        period_mm=40.0,
        periodic_phase_rad=0.3,
        thermal_ppm_per_k=12.0,
        reference_temp_c=20.0,
    )
    u = np.array([0.0, 100.0, 250.0])
    e_fwd = d.error_mm(u, np.ones(3), np.full(3, 22.0))
    e_back = d.error_mm(u, -np.ones(3), np.full(3, 22.0))
    np.testing.assert_allclose(e_fwd - e_back, (-4.0 - 60.0 * u / 1000) / 1000, atol=1e-15)
    mean = (e_fwd + e_back) / 2
    np.testing.assert_allclose(
        mean, 5e-3 * np.sin(2 * np.pi * u / 40 + 0.3) + 12e-6 * 2.0 * u, atol=1e-15
    )
    assert np.all(DriveErrors().error_mm(u, np.ones(3), np.full(3, 30.0)) == 0)


def test_directions_along_a_path_equal_each_moves_own():
    from calibench.sim.stage_drive import travel_direction, travel_directions

    rng = np.random.default_rng(2)
    path = rng.integers(0, 3, (30, 3)).astype(float)  # many moves leave an axis where it was
    last, before = np.array([-1.0, 1.0, -1.0]), np.array([1.0, 1.0, 1.0])
    one_by_one = []
    for p in path:
        last = travel_direction(before, p, last)
        before = p
        one_by_one.append(last)
    np.testing.assert_array_equal(
        travel_directions(np.array([1.0, 1.0, 1.0]), path, np.array([-1.0, 1.0, -1.0])), one_by_one
    )
