"""A task whose distribution is known, for ``calibench uncertainty``'s driver: six quantities
y = A x with x ~ N(0, diag(s^2)) drawn by the trial's seed. Its Monte Carlo and its GUM framework
agree exactly in law (a linear model of Gaussian inputs), so the study must validate it and its
95 % intervals must hold 95 % of fresh draws."""

from __future__ import annotations

import numpy as np

A = np.array(
    [
        [1.0, 0.5, 0.0],
        [0.0, 2.0, -1.0],
        [0.3, 0.0, 1.5],
        [1.0, 1.0, 1.0],
        [-2.0, 0.0, 0.5],
        [0.0, 0.2, 0.1],
    ]
)
S = np.array([3.0, 2.0, 4.0])  # the inputs' standard deviations
TASK = "a linear model of Gaussian inputs"
UNIT = "um"


def grid(config):
    """Two places, three quantities each."""
    return np.zeros((2, 1)), np.array([[0.0, 0.0, 0.0], [100.0, 50.0, 0.0]])


def labels(points):
    return [
        {"at": {"x_mm": float(p[0]), "y_mm": float(p[1])}, "quantity": a}
        for p in points
        for a in "xyz"
    ]


def trial(config, grid_q, seed):
    return A @ np.random.default_rng(seed).normal(0.0, S)


def gum(config, grid_q, seed):
    return A, np.diag(S**2)
