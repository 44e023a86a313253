"""ISO 230-2:2014 axis figures: a hand-worked example, invariances, sampling, input checks."""

import numpy as np
import pytest

from calibench.estimators.stage.iso230_2 import AXIS_FIGURES, evaluate

# --- hand-worked example: m = 3 targets, n = 3 runs per direction, deviations in um ----------
TARGETS = np.array([0.0, 250.0, 500.0])  # mm; they enter only the validation
UP = np.array([[1.0, 2.0, 3.0], [0.0, 4.0, 8.0], [-2.0, -2.0, -2.0]])
DOWN = np.array([[-1.0, -1.0, -1.0], [10.0, 10.0, 10.0], [-4.0, -1.0, 2.0]])

# Per target, worked by hand (s = sqrt(sum of squared residuals / (n - 1)), n - 1 = 2):
#   target 1  up   [1, 2, 3]    mean 2   residuals -1, 0, 1  -> s = sqrt(2/2)  = 1
#             down [-1,-1,-1]   mean -1                      -> s = 0
#             B_1 = 2 - (-1) = 3,  mean_bi = (2 - 1)/2 = 0.5
#             R↑ = 4, R↓ = 0, 2s↑ + 2s↓ + |B| = 2 + 0 + 3 = 5  -> R_1 = 5   (combined branch)
#   target 2  up   [0, 4, 8]    mean 4   residuals -4, 0, 4  -> s = sqrt(32/2) = 4
#             down [10,10,10]   mean 10                      -> s = 0
#             B_2 = 4 - 10 = -6,  mean_bi = (4 + 10)/2 = 7
#             R↑ = 16, R↓ = 0, 2s↑ + 2s↓ + |B| = 8 + 0 + 6 = 14 -> R_2 = 16  (R↑ branch)
#   target 3  up   [-2,-2,-2]   mean -2                      -> s = 0
#             down [-4,-1, 2]   mean -1  residuals -3, 0, 3  -> s = sqrt(18/2) = 3
#             B_3 = -2 - (-1) = -1,  mean_bi = (-2 - 1)/2 = -1.5
#             R↑ = 0, R↓ = 12, 2s↑ + 2s↓ + |B| = 0 + 6 + 1 = 7  -> R_3 = 12  (R↓ branch)
PER_TARGET = {
    "mean_up": [2, 4, -2],
    "mean_down": [-1, 10, -1],
    "mean_bi": [0.5, 7, -1.5],
    "reversal_i": [3, -6, -1],
    "s_up": [1, 4, 0],
    "s_down": [0, 0, 3],
    "R_up_i": [4, 16, 0],
    "R_down_i": [0, 0, 12],
    "R_i": [5, 16, 12],
}
# Axis figures, worked by hand:
#   B      = max(|3|, |-6|, |-1|)                     = 6
#   B_mean = (3 - 6 - 1)/3                            = -4/3   (signed)
#   R↑ = max(4, 16, 0) = 16;  R↓ = max(0, 0, 12) = 12;  R = max(5, 16, 12) = 16
#   E↑ = max(2, 4, -2) - min(2, 4, -2)                = 4 - (-2) = 6
#   E↓ = max(-1, 10, -1) - min(-1, 10, -1)            = 10 - (-1) = 11
#   E  = max(2, 4, -2, -1, 10, -1) - min(same)        = 10 - (-2) = 12
#   M  = max(0.5, 7, -1.5) - min(0.5, 7, -1.5)        = 7 - (-1.5) = 8.5
#   A↑: mean↑ + 2s↑ = [4, 12, -2], mean↑ - 2s↑ = [0, -4, -2]      -> 12 - (-4) = 16
#   A↓: mean↓ + 2s↓ = [-1, 10, 5], mean↓ - 2s↓ = [-1, 10, -7]     -> 10 - (-7) = 17
#   A : max(12, 10) - min(-4, -7)                                 -> 12 - (-7) = 19
AXIS = {
    "B": 6,
    "B_mean": -4 / 3,
    "R_up": 16,
    "R_down": 12,
    "R": 16,
    "E_up": 6,
    "E_down": 11,
    "E": 12,
    "M": 8.5,
    "A_up": 16,
    "A_down": 17,
    "A": 19,
}


def test_hand_worked_example_per_target():
    res = evaluate(TARGETS, UP, DOWN)
    for name, expected in PER_TARGET.items():
        assert getattr(res, name).shape == (3,), name
        assert getattr(res, name) == pytest.approx(expected, abs=1e-12), name


def test_hand_worked_example_axis_figures():
    d = evaluate(TARGETS, UP, DOWN).as_dict()
    assert tuple(d) == AXIS_FIGURES
    assert all(type(v) is float for v in d.values())
    assert d == pytest.approx(AXIS, abs=1e-12)


def test_hand_worked_example_exercises_every_branch_of_R_i():
    res = evaluate(TARGETS, UP, DOWN)
    combined = 2 * res.s_up + 2 * res.s_down + np.abs(res.reversal_i)
    assert res.R_i[0] == combined[0] > max(res.R_up_i[0], res.R_down_i[0])
    assert res.R_i[1] == res.R_up_i[1] > combined[1]
    assert res.R_i[2] == res.R_down_i[2] > combined[2]


# --- invariances ------------------------------------------------------------------------------
def _random_axis(seed, m=7, n=5):
    rng = np.random.default_rng(seed)
    targets = np.linspace(0.0, 600.0, m)
    trend = rng.normal(0.0, 5.0, (m, 1))
    return (
        targets,
        trend + 1.5 + rng.normal(0.0, 0.8, (m, n)),
        trend - 1.5 + rng.normal(0.0, 0.8, (m, n)),
    )


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_constant_offset_leaves_reversal_repeatability_and_errors_unchanged(seed):
    targets, up, down = _random_axis(seed)
    a = evaluate(targets, up, down).as_dict()
    b = evaluate(targets, up + 37.25, down + 37.25).as_dict()
    # an offset moves every mean alike and no spread; all figures are differences or spreads
    assert b == pytest.approx(a, rel=1e-12, abs=1e-9)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_swapping_directions_negates_mean_reversal_and_keeps_the_rest(seed):
    targets, up, down = _random_axis(seed)
    a = evaluate(targets, up, down)
    b = evaluate(targets, down, up)
    assert b.B_mean == pytest.approx(-a.B_mean, rel=1e-12)
    assert b.reversal_i == pytest.approx(-a.reversal_i, rel=1e-12)
    for name in ("B", "R", "E", "M", "A"):
        assert getattr(b, name) == pytest.approx(getattr(a, name), rel=1e-12), name
    for one, other in (("R_up", "R_down"), ("E_up", "E_down"), ("A_up", "A_down")):
        assert getattr(b, one) == pytest.approx(getattr(a, other), rel=1e-12), one


# --- sampling ---------------------------------------------------------------------------------
def test_known_reversal_and_scatter_are_recovered_from_many_runs():
    m, n, sigma, b = 5, 2000, 1.0, 3.0  # um
    rng = np.random.default_rng(20140301)
    targets = np.linspace(0.0, 400.0, m)
    trend = np.linspace(-2.0, 2.0, m)[:, None]
    up = trend + b / 2 + rng.normal(0.0, sigma, (m, n))
    down = trend - b / 2 + rng.normal(0.0, sigma, (m, n))
    res = evaluate(targets, up, down)
    # Standard errors for normal data: SE(B_i) = sigma sqrt(2/n) = 0.032,
    # SE(s) ~ sigma / sqrt(2(n - 1)) = 0.016, SE(4 s) = 0.063, and
    # SE(2s↑ + 2s↓ + B_i) ~ sqrt(8 SE(s)^2 + SE(B_i)^2) = sigma sqrt(6/n) = 0.055.
    # Tolerances are 5 SE (two-sided miss ~6e-7 per value, so the fixed seed is not lucky).
    se_B, se_s = sigma * np.sqrt(2 / n), sigma / np.sqrt(2 * (n - 1))
    assert res.reversal_i == pytest.approx(np.full(m, b), abs=5 * se_B)
    assert res.B == pytest.approx(b, abs=5 * se_B)
    assert res.B_mean == pytest.approx(b, abs=5 * se_B / np.sqrt(m))
    assert res.s_up == pytest.approx(np.full(m, sigma), abs=5 * se_s)
    assert res.s_down == pytest.approx(np.full(m, sigma), abs=5 * se_s)
    assert res.R_up_i == pytest.approx(np.full(m, 4 * sigma), abs=5 * 4 * se_s)
    assert res.R_down_i == pytest.approx(np.full(m, 4 * sigma), abs=5 * 4 * se_s)
    # with b > 0 the combined band 4 sigma + b wins over either 4 sigma
    assert res.R_i == pytest.approx(np.full(m, 4 * sigma + b), abs=5 * sigma * np.sqrt(6 / n))


# --- input checks -----------------------------------------------------------------------------
@pytest.mark.parametrize(
    "targets, up, down, match",
    [
        (TARGETS, UP[:, :1], DOWN[:, :1], "at least 2"),  # n = 1 run
        (TARGETS, UP, DOWN[:, :2], "shape mismatch"),  # up and down differ
        (TARGETS[:2], UP, DOWN, "shape mismatch"),  # targets vs rows
        (TARGETS, UP[0], DOWN[0], "shape mismatch"),  # deviations not 2-D
        (TARGETS[:1], UP[:1], DOWN[:1], "at least 2"),  # m = 1 target
        (TARGETS, np.where(UP == 4.0, np.nan, UP), DOWN, "finite"),  # NaN deviation
        (TARGETS, UP, np.where(DOWN == 10.0, np.inf, DOWN), "finite"),  # inf deviation
        (np.array([0.0, np.nan, 500.0]), UP, DOWN, "finite"),  # NaN target
    ],
)
def test_invalid_input_raises_value_error(targets, up, down, match):
    with pytest.raises(ValueError, match=match):
        evaluate(targets, up, down)


def test_run_and_target_count_messages_name_the_cause():
    with pytest.raises(ValueError, match="run"):
        evaluate(TARGETS, UP[:, :1], DOWN[:, :1])
    with pytest.raises(ValueError, match="target"):
        evaluate(TARGETS[:1], UP[:1], DOWN[:1])
