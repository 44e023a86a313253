"""The uncertainty tasks' Jacobians (issue 64): what the GUM framework propagates must be how
the task's value moves with each parameter, checked by central differences (mink's habit)."""

import numpy as np

from calibench.scenarios.arm_cmm import uncertainty as arm
from calibench.scenarios.arm_cmm.scenario import ArmCmmConfig


def test_the_arm_tasks_jacobian_is_its_points_differences():
    """Each kept parameter moved by 1e-6 of its typical size either way (the frames' by a left
    rotation, as the solver moves them): the calibrated model's points at the grid move as the
    Jacobian says, to 1e-6 of the largest column."""
    config = ArmCmmConfig()
    grid_q, _ = arm.grid(config)
    _, cal = arm.calibrated(config, 3)
    p, s = cal.problem, cal.state
    J = arm.task_jacobian(cal, grid_q)
    kept = cal.ident.basis.kept
    h = 1e-6 * p.scales()[kept]
    numeric = np.empty_like(J)
    for col, (k, step) in enumerate(zip(kept, h)):
        e = np.zeros(len(p.names))
        e[k] = step
        plus = p.model(p.update(s, e), grid_q, frame=0).ravel()
        minus = p.model(p.update(s, -e), grid_q, frame=0).ravel()
        numeric[:, col] = (plus - minus) / (2 * step)
    scale = np.abs(J * h).max()
    np.testing.assert_allclose(J * h, numeric * h, atol=1e-6 * scale)


def test_the_stage_tasks_jacobian_is_the_compensations_differences():
    """A map's coefficient moved a little either way: the compensated command's landing (on the
    true maps) moves at each target as minus the Jacobian's column says, to second order in the
    maps' slopes (their product with the move: under 1e-3 of it)."""
    from calibench.estimators.stage.error_map import QuadraticFit, compensated_command
    from calibench.scenarios.belt_stage import uncertainty as stage
    from calibench.scenarios.belt_stage.scenario import BeltStageConfig

    targets, _ = stage.grid(BeltStageConfig())
    coef = np.array([0.0, 2e-4, -1e-4, 3e-7, -2e-7, 1e-7])  # mm, mm / mm, mm / mm^2

    def fit(c):
        return QuadraticFit(c, np.zeros(6), 0.0, None, 0.0, 50)

    def landing(cx, cy):
        x, y = compensated_command(targets[:, 0], targets[:, 1], fit(cx), fit(cy))
        truth_x, truth_y = fit(coef), fit(coef)  # the stage's true maps
        return np.stack([x + truth_x(x, y), y + truth_y(x, y)], 1).ravel()

    J = stage.task_jacobian(targets)
    for k in range(12):
        step = 1e-6 * 10.0 ** -([0, 1, 1, 3, 3, 3][k % 6])
        d = np.zeros(12)
        d[k] = step
        plus = landing(coef + d[:6], coef + d[6:])
        minus = landing(coef - d[:6], coef - d[6:])
        np.testing.assert_allclose(
            (plus - minus) / 2, J[:, k] * step, atol=1e-3 * abs(step) * np.abs(J[:, k]).max()
        )


def test_the_stage_tasks_gum_u_is_its_trials_spread():
    """60 machines' compensated errors scatter as the GUM framework's u says at every target:
    the ratio within the chi band of 60 values (4 of its standard errors, 1 / sqrt(120) each)
    widened by 1.25, the reference machine's u being one machine's (its spread over machines:
    some 10 %). Without the common modes' correlation across the maps (a focal length's error
    moves both maps' slopes) the GUM's u was half the spread (ratios 0.3-0.8)."""
    from calibench.estimators.uncertainty.gum import propagate
    from calibench.scenarios.belt_stage import uncertainty as stage
    from calibench.scenarios.belt_stage.scenario import BeltStageConfig

    config = BeltStageConfig()
    targets, _ = stage.grid(config)
    u = propagate(*stage.gum(config, targets, 0))
    errors = np.array([stage.trial(config, targets, 1000 + k) for k in range(60)])
    ratio = errors.std(axis=0, ddof=1) / u
    band = 4 / np.sqrt(2 * 60)
    assert np.all(ratio > (1 - band) / 1.25) and np.all(ratio < (1 + band) * 1.25), ratio
