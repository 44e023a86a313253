"""Parts heated through heat capacities: the third suite's thermal mechanisms (issue 61),
simulated rather than written.

A thin part (a scale's tape, a leg's tube) sits on a heavy one (the base casting, the leg's
motor) and both exchange heat with the air; heat may also enter the heavy part (a motor's
copper loss):

    C_0 dT_0/dt = G_0a (T_air - T_0) + G_01 (T_1 - T_0) + P(t)
    C_1 dT_1/dt = G_01 (T_0 - T_1) + G_1a (T_air - T_1)

integrated in time by an implicit solver (``scipy.integrate.solve_ivp``, Radau) from both parts
settled at the first logged temperature, the air and the heat between samples interpolated. The
thin part's temperature is a second-order response, not the first-order lag any candidate
writes.

- ``heated_scale`` (stages): the room warms 2-5 K and the logged air says so; each axis's scale
  (bonded to the base) expands ``k (T_1 - T_1(0)) u``, ``u`` the axis's position. Nearest:
  ``thermal_expansion`` on each axis, its lag about the network's mean delay.
- ``heated_leg`` (Stewart platform): one leg's motor has no brake and holds its load with
  current, so its copper loss goes as the square of the leg's axial force (MuJoCo's statics
  under each pose's payload); its tube warms through the motor and grows ``k (T_1 - T_1(0)) L``
  that the screw's sensor does not see, the room quiet and no temperature logged for it.
  Nearest: ``thermal_drift`` on that leg (a warm-up in time, its ripple the payload's).
- ``heated_mount`` (probe scanner): the room warms 1.5-3 K over the turns and the logged air says
  so; the stylus mount warms through the probe's column and moves the probe's zero
  ``k (T_1 - T_1(0))``. Nearest: ``thermal_drift`` of the probe's reading.

Units: times s, temperatures deg C, heat capacities relative to the heavy part's (only ratios of
capacity to conductance matter), heat in K/s of the heavy part, ``k`` ppm/K (the mount's mm/K).
"""

from __future__ import annotations

import numpy as np
from scipy.integrate import solve_ivp

SIMULATED_STAGE_KINDS = ("heated_scale",)
SIMULATED_STEWART_KINDS = ("heated_leg",)
SIMULATED_SCANNER_KINDS = ("heated_mount",)
BASE_LAG_S = (20 * 60.0, 50 * 60.0)  # the base casting's time constant against the air
SCALE_LAG_S = (3 * 60.0, 10 * 60.0)  # the scale's, against the base and air together
AIR_SHARE = (0.1, 0.4)  # the scale's conductance that goes to the air, not the base
CAPACITY_RATIO = (0.02, 0.1)  # the scale's heat capacity over the base's
PPM_PER_K = (10.0, 25.0)  # a steel tape's to an aluminium carrier's
# a leg's motor and gearbox housing against the air and its tube (a servo motor's thermal time
# constant is 20-60 min)
MOTOR_LAG_S = (20 * 60.0, 45 * 60.0)
TUBE_LAG_S = (3 * 60.0, 8 * 60.0)
LEG_RISE_K = (1.5, 4.0)  # the tube's warming by the recording's end
# the scanner's probe column against the air, and its stylus mount's against the column and the
# air: a recording is a minute or two, so parts of seconds to minutes
COLUMN_LAG_S = (60.0, 150.0)
MOUNT_LAG_S = (10.0, 40.0)
MOUNT_UM_PER_K = (6.0, 12.0)  # the probe's zero, per kelvin of the mount


def network(
    tau_base_s: float, tau_scale_s: float, air_share: float, capacity_ratio: float
) -> tuple[np.ndarray, np.ndarray]:
    """The network's state equation ``x' = A x + b T_air`` (x: the heavy part's and the thin
    part's temperatures), ``A`` (2, 2) and ``b`` (2,), in 1/s, from the heavy part's time
    constant against the air, the thin part's against both, the share of the thin part's
    conductance that goes to the air and its capacity over the heavy part's (which is 1)."""
    G_ba = 1.0 / tau_base_s
    C_s = capacity_ratio
    G_s = C_s / tau_scale_s  # the scale's whole conductance, to base and air
    G_bs, G_sa = (1 - air_share) * G_s, air_share * G_s
    A = np.array([[-(G_ba + G_bs), G_bs], [G_bs / C_s, -(G_bs + G_sa) / C_s]])
    b = np.array([G_ba, G_sa / C_s])
    return A, b


def mean_delay_s(A: np.ndarray, b: np.ndarray) -> float:
    """How far (s) the thin part's temperature trails a steady ramp of the air: the mean of its
    impulse response, ``-H'(0) = c A^-2 b`` with ``c`` the thin part's row (``H(0)`` is 1)."""
    Ainv = np.linalg.inv(A)
    return float((Ainv @ Ainv @ b)[1])


def thin_temperature(
    t_s: np.ndarray,
    air_c: np.ndarray,
    A: np.ndarray,
    b: np.ndarray,
    heat_k_per_s: np.ndarray | None = None,
) -> np.ndarray:
    """The thin part's temperature (n,) at the times ``t_s`` (n,, increasing) of an air logged
    as ``air_c`` (n,), the network ``A``, ``b`` (:func:`network`) settled at ``air_c[0]``, with
    ``heat_k_per_s`` (n,) entering the heavy part (None: none)."""
    heat = np.zeros(len(t_s)) if heat_k_per_s is None else heat_k_per_s

    def slope(t: float, x: np.ndarray) -> np.ndarray:
        return A @ x + b * np.interp(t, t_s, air_c) + np.array([np.interp(t, t_s, heat), 0.0])

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
        raise RuntimeError(f"the network's heat did not integrate: {sol.message}")
    return sol.y[1]


def _drawn_network(
    rng: np.random.Generator, heavy_lag_s: tuple, thin_lag_s: tuple
) -> tuple[np.ndarray, np.ndarray, float, dict]:
    """A network drawn from the ranges (its heavy and thin parts' time constants, the air's
    share, the capacity ratio, in that order) and the thin part's expansion ``k`` ppm/K:
    ``A``, ``b``, ``k`` and the draws."""
    taus = rng.uniform(*heavy_lag_s), rng.uniform(*thin_lag_s)
    share, ratio, k = (
        rng.uniform(*AIR_SHARE),
        rng.uniform(*CAPACITY_RATIO),
        rng.uniform(*PPM_PER_K),
    )
    A, b = network(*taus, share, ratio)
    physics = {"heavy_lag_s": taus[0], "thin_lag_s": taus[1], "air_share": share}
    return A, b, float(k), {**physics, "capacity_ratio": ratio}


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
        A, b, k, physics = _drawn_network(rng, BASE_LAG_S, SCALE_LAG_S)
        scale_c = thin_temperature(t, temp_c, A, b)
        err[:, i] = k * 1e-6 * (scale_c - scale_c[0]) * np.asarray(c[a], float)
        effects.append(
            {
                "name": "heated_scale",
                "axis": a,
                "nearest": "thermal_expansion",
                "alike": ["thermal_drift"],
                "params": {"ppm_per_k": k, "lag_s": mean_delay_s(A, b)},
                "physics": {
                    "base_lag_s": physics["heavy_lag_s"],
                    "scale_lag_s": physics["thin_lag_s"],
                    "air_share": physics["air_share"],
                    "capacity_ratio": physics["capacity_ratio"],
                },
            }
        )
    return err, effects, temp_c


def heated_leg(
    rng: np.random.Generator, t_s: np.ndarray, force_n: np.ndarray, L_mm: np.ndarray, leg: int
) -> tuple[np.ndarray, dict]:
    """How short (n,) mm leg ``leg`` (1-6) reads while its brakeless motor's copper loss, as the
    square of its axial force ``force_n`` (n, 6) N, warms its tube through the network (the
    room's air steady), the tube's growth ``k dT L_mm`` of its length (n, 6); and the truth.
    The motor's power is set so that the tube ends 1.5-4 K warm."""
    i = leg - 1
    A, b, k, physics = _drawn_network(rng, MOTOR_LAG_S, TUBE_LAG_S)
    loss = (force_n[:, i] / np.abs(force_n[:, i]).max()) ** 2  # I^2 R: the holding current's
    still = np.zeros(len(t_s))
    unit = thin_temperature(
        t_s, still, A, b, loss / physics["heavy_lag_s"]
    )  # 1 K steady at the largest load
    rise = rng.uniform(*LEG_RISE_K)
    tube_k = unit * rise / unit[-1]
    short_mm = k * 1e-6 * tube_k * L_mm[:, i]
    return short_mm, {
        "name": "heated_leg",
        "axis": "legs",
        "nearest": "thermal_drift",
        "params": {"leg": leg, "ppm_per_k": k, "rise_k": rise},
        "physics": {
            "motor_lag_s": physics["heavy_lag_s"],
            "tube_lag_s": physics["thin_lag_s"],
            "air_share": physics["air_share"],
            "capacity_ratio": physics["capacity_ratio"],
            "largest_force_n": float(np.abs(force_n[:, i]).max()),
        },
    }


def heated_mount(
    rng: np.random.Generator, t_s: np.ndarray, temp_c: np.ndarray
) -> tuple[np.ndarray, dict, np.ndarray]:
    """How far (n,) mm the probe's zero moves while its stylus mount, on the probe's column,
    warms through the network as the room warms 1.5-3 K over the recording (logged); the truth
    and the logged temperature (n,). The mount's growth moves the zero 6-12 um per kelvin of it.
    Nearest: ``thermal_drift`` of the probe's reading, its lag about the network's mean delay."""
    t = np.asarray(t_s, float)
    rise, tau_air = rng.uniform(1.5, 3.0), t[-1] / rng.uniform(1.5, 3)
    temp_c = temp_c + rise * (1 - np.exp(-t / tau_air))
    A, b, _, physics = _drawn_network(rng, COLUMN_LAG_S, MOUNT_LAG_S)
    k = rng.uniform(*MOUNT_UM_PER_K) / 1000
    mount_c = thin_temperature(t, temp_c, A, b)
    grown_mm = k * (mount_c - mount_c[0])
    return (
        grown_mm,
        {
            "name": "heated_mount",
            "axis": "rho",
            "nearest": "thermal_drift",
            "params": {"mm_per_k": k, "lag_s": mean_delay_s(A, b)},
            # its size where it acts, about its mean (the rail's dL takes a constant): a column
            # lagging the air by minutes warms the mount little over a recording of a minute
            "rms_um": 1000 * float(np.std(grown_mm)),
            "physics": {
                "column_lag_s": physics["heavy_lag_s"],
                "mount_lag_s": physics["thin_lag_s"],
                "air_share": physics["air_share"],
                "capacity_ratio": physics["capacity_ratio"],
            },
        },
        temp_c,
    )
