"""A stage's scales heated through the machine's heat capacities: the third suite's stage effect
(issue 61), simulated rather than written.

The room warms and the logged air says so; the scales do not follow it. Each axis's scale is a
thin tape bonded to the machine's base, a heavy casting, and exchanges heat with both:

    C_b dT_b/dt = G_ba (T_air - T_b) + G_bs (T_s - T_b)
    C_s dT_s/dt = G_bs (T_b - T_s) + G_sa (T_air - T_s)

integrated in time by an implicit solver (``scipy.integrate.solve_ivp``, Radau) from a base and
scale settled at the first logged temperature, the air between log entries interpolated. The
reading is off by the scale's expansion, ``k (T_s - T_s(0)) u``, ``u`` the axis's position. No
candidate writes this: the scale's temperature is a second-order response of the air (the base's
slow lag, the bond's fast one, and the share the scale takes from the air directly), not the
first-order lag of ``thermal_expansion``'s ``lag_s``. Nearest: ``thermal_expansion`` on each
axis, its lag about the network's mean delay.

Units: times s, temperatures deg C, heat capacities relative to the base's (only ratios of
capacity to conductance matter), ``k`` ppm/K.
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

SIMULATED_STAGE_KINDS = ("heated_scale",)
BASE_LAG_S = (20 * 60.0, 50 * 60.0)  # the base casting's time constant against the air
SCALE_LAG_S = (3 * 60.0, 10 * 60.0)  # the scale's, against the base and air together
AIR_SHARE = (0.1, 0.4)  # the scale's conductance that goes to the air, not the base
CAPACITY_RATIO = (0.02, 0.1)  # the scale's heat capacity over the base's
PPM_PER_K = (10.0, 25.0)  # a steel tape's to an aluminium carrier's


def network(
    tau_base_s: float, tau_scale_s: float, air_share: float, capacity_ratio: float
) -> tuple[np.ndarray, np.ndarray]:
    """The network's state equation ``x' = A x + b T_air`` (x: base, scale), ``A`` (2, 2) and
    ``b`` (2,), in 1/s, from its time constants and shares (the base's capacity 1)."""
    G_ba = 1.0 / tau_base_s
    C_s = capacity_ratio
    G_s = C_s / tau_scale_s  # the scale's whole conductance, to base and air
    G_bs, G_sa = (1 - air_share) * G_s, air_share * G_s
    A = np.array([[-(G_ba + G_bs), G_bs], [G_bs / C_s, -(G_bs + G_sa) / C_s]])
    b = np.array([G_ba, G_sa / C_s])
    return A, b


def mean_delay_s(A: np.ndarray, b: np.ndarray) -> float:
    """How far (s) the scale's temperature trails a steady ramp of the air: the mean of its
    impulse response, ``-H'(0) = c A^-2 b`` with ``c`` the scale's row (``H(0)`` is 1)."""
    Ainv = np.linalg.inv(A)
    return float((Ainv @ Ainv @ b)[1])


def scale_temperature(
    t_s: np.ndarray, air_c: np.ndarray, A: np.ndarray, b: np.ndarray
) -> np.ndarray:
    """The scale's temperature (n,) at the times ``t_s`` (n,, increasing) of an air logged as
    ``air_c`` (n,), the network ``A``, ``b`` (:func:`network`) settled at ``air_c[0]``."""

    def slope(t: float, x: np.ndarray) -> np.ndarray:
        return A @ x + b * np.interp(t, t_s, air_c)

    fastest = 1.0 / np.max(np.abs(np.linalg.eigvals(A)))
    sol = solve_ivp(
        slope,
        (float(t_s[0]), float(t_s[-1])),
        np.full(2, air_c[0]),
        method="Radau",
        t_eval=t_s,
        jac=lambda t, x: A,
        rtol=1e-8,
        atol=1e-9,
        max_step=fastest,
    )
    if not sol.success:
        raise RuntimeError(f"the scale's heat did not integrate: {sol.message}")
    return sol.y[1]


def heated_scale(
    rng: np.random.Generator, c: dict, temp_c: np.ndarray
) -> tuple[np.ndarray, list[dict], np.ndarray]:
    """The error (n, 2) mm of both axes' scales heated through the network as the room warms by
    2-5 K over the recording (logged), their truth and the logged temperature.

    Parameters
    ----------
    rng : numpy.random.Generator
        The recording's generator.
    c : dict
        The plan's commands (``stage_commands``): ``x``, ``y``, ``t_s``.
    temp_c : (n,) the logged air temperature before the room warms.

    Returns
    -------
    err : (n, 2) ndarray
    effects : list of dict
        Per axis, with ``nearest`` ``thermal_expansion`` and ``alike`` ``thermal_drift`` (a
        scale warming while the carriage stands mid-travel is an offset too).
    temp_c : (n,) ndarray
    """
    t = np.asarray(c["t_s"], float)
    rise, tau_air = rng.uniform(2, 5), t[-1] / rng.uniform(1.5, 3)
    temp_c = temp_c + rise * (1 - np.exp(-t / tau_air))
    err, effects = np.zeros((len(t), 2)), []
    for i, a in enumerate("xy"):  # each axis's scale on its own part of the base
        taus = rng.uniform(*BASE_LAG_S), rng.uniform(*SCALE_LAG_S)
        share, ratio, k = (
            rng.uniform(*AIR_SHARE),
            rng.uniform(*CAPACITY_RATIO),
            rng.uniform(*PPM_PER_K),
        )
        A, b = network(*taus, share, ratio)
        scale_c = scale_temperature(t, temp_c, A, b)
        err[:, i] = k * 1e-6 * (scale_c - scale_c[0]) * np.asarray(c[a], float)
        effects.append(
            {
                "name": "heated_scale",
                "axis": a,
                "nearest": "thermal_expansion",
                "alike": ["thermal_drift"],
                "params": {"ppm_per_k": k, "lag_s": mean_delay_s(A, b)},
                "physics": {
                    "base_lag_s": taus[0],
                    "scale_lag_s": taus[1],
                    "air_share": share,
                    "capacity_ratio": ratio,
                },
            }
        )
    return err, effects, temp_c
