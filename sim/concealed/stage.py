"""Blinded stage recordings (belt-stage, vision-stage) with concealed effects.

Kinds: ``null``, ``backlash``, ``periodic``, ``thermal``, ``combined`` (backlash + periodic +
thermal), ``bump`` (a local defect no candidate has), ``mixed`` (lost motion, a periodic error
and thermal expansion all on one axis, the temperature rising over the passes), ``elastic`` (belt
stage: one axis's belt elastic against the carriage's friction, by MuJoCo's tendons: lost motion
that grows along the travel).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from calibench.recordings import StageRecording
from calibench.sim.concealed.effects import (
    draw_lost_motion_mm,
    draw_periodic,
    effect,
    expansion_mm,
    lost_motion_mm,
    periodic_mm,
)
from calibench.sim.concealed.heat import SIMULATED_STAGE_KINDS, heated_scale
from calibench.sim.concealed.noise import read, reading_noise
from calibench.sim.concealed.sessions import (
    ROOM_C,
    first_order_rise,
    manifest,
    room_temperature,
    session_generator,
)
from calibench.sim.concealed.unwritten import UNWRITTEN_STAGE_KINDS, stage_effect
from calibench.sim.replay import replay_stage
from calibench.sim.stage_drive import travel_direction

STAGE_KINDS = ("null", "backlash", "periodic", "thermal", "combined", "bump", "mixed", "elastic")
REFERENCE_NOISE_UM = 1.0  # the reference instrument (interferometer / microscope), 1-sigma
PASS_OFFSET_UM = 0.3  # each pass's own offset: correlated noise that must not become a term


@dataclasses.dataclass(frozen=True)
class StagePlan:
    """ISO 230-2 style lines: along X at three Y levels and along Y at three X levels, each
    forward then backward, ``passes`` times.

    Attributes
    ----------
    travel_mm : tuple of float
        (X, Y) travel, mm; the lines run from 0 to it.
    step_mm : float
        Between stations along a line, mm: fine enough for a 30 mm period.
    passes : int
        How many times the six lines are run.
    seconds_per_station : float
        The time a station takes, s (the recording's clock).
    """

    travel_mm: tuple[float, float]
    step_mm: float
    passes: int = 4
    seconds_per_station: float = 3.0


PLANS = {
    "belt-stage": StagePlan((500.0, 400.0), 6.5),
    "vision-stage": StagePlan((300.0, 200.0), 4.5),
}


def twin_geometry(scenario: str):
    """The stage twin's default nominal geometry for ``scenario`` (its scene's defaults)."""
    from calibench.scenes.belt_stage import BeltStageGeometry
    from calibench.scenes.vision_stage import VisionStageGeometry

    return {"belt-stage": BeltStageGeometry, "vision-stage": VisionStageGeometry}[scenario]()


def stage_commands(plan: StagePlan) -> dict:
    """The plan's stations in the order they are visited.

    Parameters
    ----------
    plan : StagePlan
        The lines, their step and passes.

    Returns
    -------
    dict of str to ndarray
        (n,) each: ``x``, ``y`` the commanded position (mm), ``run`` the pass id, ``dir_x``,
        ``dir_y`` the direction each axis last moved (+1 / -1; homed from below), ``t_s`` the
        time, s.
    """
    tx, ty = plan.travel_mm
    xs, ys = np.arange(0, tx + 1e-9, plan.step_mm), np.arange(0, ty + 1e-9, plan.step_mm)
    rows = []
    for p in range(plan.passes):
        for y0 in (0.15 * ty, 0.5 * ty, 0.85 * ty):
            rows += [(x, y0, p) for x in xs] + [(x, y0, p) for x in xs[::-1]]
        for x0 in (0.15 * tx, 0.5 * tx, 0.85 * tx):
            rows += [(x0, y, p) for y in ys] + [(x0, y, p) for y in ys[::-1]]
    c = np.array(rows)
    x, y = c[:, 0], c[:, 1]
    dirs = np.zeros((len(c), 2))
    last = np.array([1.0, 1.0])
    prev = np.array([-1.0, -1.0])  # homed from below
    for i, pos in enumerate(c[:, :2]):
        last = travel_direction(prev, pos, last)
        dirs[i], prev = last, pos
    return {
        "x": x,
        "y": y,
        "run": c[:, 2],
        "dir_x": dirs[:, 0],
        "dir_y": dirs[:, 1],
        "t_s": np.arange(len(c)) * plan.seconds_per_station,
    }


def stage_recording(
    scenario: str,
    kind: str,
    seed: int,
    noise: str = "gaussian",
    rise_k: float | None = None,
    warmer_k: float = 0.0,
    repeat: int = 0,
    plan: StagePlan | None = None,
    truth=None,
    geometry=None,
) -> tuple[StageRecording, dict]:
    """A blinded stage recording: the twin replayed along the plan's lines, the as-built map, a
    wandering room temperature, each pass's offset and the reference's noise, with the concealed
    effect of ``kind``.

    Parameters
    ----------
    scenario : str
        ``belt-stage`` or ``vision-stage`` (a key of ``PLANS``).
    kind : str
        One of ``STAGE_KINDS`` (``elastic`` for the belt stage only), of the second suite's
        ``unwritten.UNWRITTEN_STAGE_KINDS`` or the third's ``heat.SIMULATED_STAGE_KINDS``.
    seed : int
        Every draw's seed: the same seed gives the same recording, bit for bit.
    noise : str
        The reference's reading noise, one of ``noise.NOISE_KINDS`` (``gaussian``: as every
        estimator assumes) or ``quantised``.
    rise_k : float or None
        ``thermal``'s rise of the room over the recording, K; None: drawn (2-5 K).
    warmer_k : float
        The room this much warmer than in the seed's first recording: a second recording of
        the same machine (its errors the same draws, its temperature's wander, pass offsets and
        noise fresh), its expansion counted from the first's temperature. 0: the recording as
        always.
    repeat : int
        The same machine recorded again along the same plan: its errors and the room the same
        draws, its pass offsets and noise fresh (``k`` > 0: the ``k``-th repeat; 0: the first
        recording). What a structure chosen on the first is scored on.
    plan : StagePlan or None
        The lines recorded; None: the scenario's ``PLANS`` entry.
    truth, geometry : the twin's ``*Truth`` and ``*Geometry``, or None
        The twin replayed (a ``run --config`` file's: its error map, drives, belts); None: the
        scenario's defaults. The concealed effects are added on top of its motion.

    Returns
    -------
    recording : StageRecording
        (n,) each field, mm; what ``discover`` reads.
    manifest : dict
        The sealed truth: scenario, kind, seed, the effects with their parameters, the reference
        noise in um.

    Raises
    ------
    ValueError
        An unknown kind, or ``elastic`` on the vision stage.
    """
    if kind not in STAGE_KINDS + UNWRITTEN_STAGE_KINDS + SIMULATED_STAGE_KINDS:
        raise ValueError(f"unknown kind {kind!r}")
    rng = np.random.default_rng(seed)
    plan = plan or PLANS[scenario]
    c = stage_commands(plan)
    x, y, n = c["x"], c["y"], len(c["x"])
    effects = []
    if kind == "elastic":
        if scenario != "belt-stage":
            raise ValueError("an elastic belt is the belt stage's")
        a = str(rng.choice(["x", "y"]))
        pos, elastic = _elastic_belt(a, rng, x, y, truth, geometry)
        effects.append(elastic)
    else:  # replayed once the room's temperature is known (a twin's drives may expand with it)
        pos = None
    err = as_built_map_mm(rng, x, y, plan.travel_mm)
    T = room_temperature(rng, n, 0.002)  # a quiet room: the logged temperature wanders
    # a warmer session or a repeat: the same machine, its own pass offsets and noise (a warmer
    # one its own wander too)
    session = session_generator(rng, seed, warmer_k, round(1000 * warmer_k), repeat)
    if warmer_k:
        T = room_temperature(session, n, 0.002, ROOM_C + warmer_k)
    reference = T[0] - warmer_k  # what the machine's scale is calibrated at
    err, T, found = concealed_errors(kind, rng, c, plan.travel_mm, err, T, reference, rise_k)
    effects += found
    run = c["run"].astype(int)
    err += session.normal(0, PASS_OFFSET_UM / 1000, (plan.passes, 2))[run]
    err += reading_noise(noise, session, (n, 2), REFERENCE_NOISE_UM / 1000)
    if pos is None:
        temp = None if truth is None else T
        pos = replay_stage(geometry or twin_geometry(scenario), x, y, temp_c=temp, truth=truth)
    meas = read(noise, pos + err, REFERENCE_NOISE_UM / 1000)
    rec = StageRecording(
        x_cmd_mm=x,
        y_cmd_mm=y,
        x_meas_mm=meas[:, 0],
        y_meas_mm=meas[:, 1],
        t_s=c["t_s"],
        dir_x=c["dir_x"],
        dir_y=c["dir_y"],
        temp_c=np.round(T, 3),
        run=run.astype(float),
    )
    return rec, manifest(
        scenario, kind, seed, effects, REFERENCE_NOISE_UM, noise, warmer_k=warmer_k, repeat=repeat
    )


def as_built_map_mm(
    rng: np.random.Generator, x_mm: np.ndarray, y_mm: np.ndarray, travel_mm: tuple[float, float]
) -> np.ndarray:
    """How the as-built machine differs smoothly from the twin at the commands ``x_mm``,
    ``y_mm`` (n,): per axis a quadratic in the travel's fractions, its six coefficients
    N(0, 0.02 mm) (the scene's model absorbs this); (n, 2) mm."""
    n = len(x_mm)
    err = np.zeros((n, 2))
    u, v = x_mm / travel_mm[0], y_mm / travel_mm[1]
    for k in range(2):
        err[:, k] += rng.normal(0, 0.02, 6) @ np.stack([np.ones(n), u, v, u * u, u * v, v * v])
    return err


def concealed_errors(
    kind: str,
    rng: np.random.Generator,
    c: dict,
    travel_mm: tuple[float, float],
    err_mm: np.ndarray,
    temp_c: np.ndarray,
    reference_c: float,
    rise_k: float | None,
) -> tuple[np.ndarray, np.ndarray, list[dict]]:
    """The concealed effects of ``kind`` added to the machine's errors, in their order of draws.

    Parameters
    ----------
    kind : str
        The recording's kind.
    rng : numpy.random.Generator
        The machine's generator.
    c : dict
        :func:`stage_commands`'s.
    travel_mm : tuple of float
        (X, Y) the plan's travel, mm.
    err_mm : ndarray
        (n, 2) the machine's errors so far, mm.
    temp_c : ndarray
        (n,) the room's logged temperature, deg C.
    reference_c : float
        The temperature the machine's scale is calibrated at, deg C.
    rise_k : float or None
        ``thermal``'s rise, K; None: drawn.

    Returns
    -------
    err_mm : ndarray
        (n, 2) the errors with the effects, mm.
    temp_c : ndarray
        (n,) the logged temperature (risen where the kind warms the room), deg C.
    effects : list of dict
        The effects' records.
    """
    x, y = c["x"], c["y"]
    wanted = {
        "combined": ("backlash", "periodic", "thermal"),
        "mixed": ("backlash", "periodic", "thermal"),
    }.get(kind, (kind,))
    axis_of = {"x": 0, "y": 1}
    pick = [str(a) for a in rng.permutation(["x", "y"])]
    effects = []
    if "backlash" in wanted:
        a = pick[0]
        B = draw_lost_motion_mm(rng)
        err_mm[:, axis_of[a]] += lost_motion_mm(B, c[f"dir_{a}"])
        effects.append(effect("backlash", a, reversal_mm=B))
    if "periodic" in wanted:
        a = pick[1] if kind == "combined" else pick[0]
        P, A, ph = draw_periodic(rng, (30, 100), (4, 10))
        err_mm[:, axis_of[a]] += periodic_mm(x if a == "x" else y, P, A, ph)
        effects.append(effect("periodic", a, period_mm=P, amplitude_mm=A))
    if "thermal" in wanted:
        temp_c, found = thermal_expansion(
            rng, c["t_s"], x, y, err_mm, temp_c, reference_c, rise_k, pick[0], kind == "mixed"
        )
        effects += found
    if kind == "bump":
        x0, w, h = (
            rng.uniform(0.2, 0.8) * travel_mm[0],
            rng.uniform(8, 15),
            rng.uniform(8, 15) / 1000,
        )
        # the X rail's bump lifts the carriage sideways
        err_mm[:, 1] += h * np.exp(-0.5 * ((x - x0) / w) ** 2)
        effects.append(effect("nonsmooth", "y", x_mm=x0, width_mm=w, height_mm=h))
    if kind in UNWRITTEN_STAGE_KINDS:  # the second suite's: no candidate writes them down
        more, truths, temp_c = stage_effect(kind, rng, c, travel_mm, temp_c)
        err_mm += more
        effects += truths
    if kind in SIMULATED_STAGE_KINDS:  # the third suite's: the scales' heat, integrated
        more, truths, temp_c = heated_scale(rng, c, temp_c)
        err_mm += more
        effects += truths
    return err_mm, temp_c, effects


def thermal_expansion(
    rng: np.random.Generator,
    t_s: np.ndarray,
    x_mm: np.ndarray,
    y_mm: np.ndarray,
    err_mm: np.ndarray,
    temp_c: np.ndarray,
    reference_c: float,
    rise_k: float | None,
    only: str,
    one_axis: bool,
) -> tuple[np.ndarray, list[dict]]:
    """The room rising 2-5 K (``rise_k`` if given) over a first-order time constant of a third
    to two thirds of the recording, and the scales expanding 10-25 ppm/K against the part
    (aluminium vs glass) on both axes (``one_axis``: on ``only``), added to ``err_mm`` (n, 2)
    mm in place. Returns the risen temperature (n,) deg C and the effects' records."""
    rise, tau = rng.uniform(2, 5), t_s[-1] / rng.uniform(1.5, 3)
    rise = rise if rise_k is None else rise_k
    temp_c = temp_c + first_order_rise(t_s, rise, tau)
    k = rng.uniform(10, 25)  # ppm/K: the scale's mismatch with the part (aluminium vs glass)
    effects = []
    for i, (a, u_a) in enumerate((("x", x_mm), ("y", y_mm))):
        if one_axis and a != only:  # all three on one axis
            continue
        err_mm[:, i] += expansion_mm(k, temp_c, reference_c, u_a)
        effects.append({**effect("thermal_expansion", a, ppm_per_k=k), "temperature_rise_k": rise})
    return temp_c, effects


def _elastic_belt(
    axis: str, rng: np.random.Generator, x: np.ndarray, y: np.ndarray, twin=None, geometry=None
) -> tuple[np.ndarray, dict]:
    """The belt stage's twin with ``axis``'s belt elastic (EA 25-50 kN against 2-5 N of carriage
    friction) at the commands, (n, 2) mm, and the effect's truth: the reversal measured on the
    elastic belt itself (MuJoCo), approached from either side at the ends and middle of the
    travel."""
    from calibench.scenes.belt_stage import BeltStageGeometry
    from calibench.sim.belt_stage import BeltStageTruth
    from calibench.sim.stage_drive import BeltDrive, ElasticBelt

    belt = BeltDrive(ea_n=rng.uniform(25e3, 50e3), friction_n=rng.uniform(2.0, 5.0))
    # on top of the twin's own motion (a config's truth and geometry; default: the scenario's)
    truth = dataclasses.replace(twin or BeltStageTruth(), **{f"belt_{axis}": belt})
    geometry = geometry or BeltStageGeometry()
    pos = replay_stage(geometry, x, y, truth=truth)
    u = x if axis == "x" else y
    travel = geometry.travel_mm["xy".index(axis)]

    def reversal(at: float) -> float:
        b = ElasticBelt(travel, belt)
        b.move(at - 5.0)
        up = b.move(at)
        b.move(at + 5.0)
        return up - b.move(at)

    lo, hi = float(u.min()), float(u.max())
    start, mid, end = reversal(lo), reversal((lo + hi) / 2), reversal(hi)
    return pos, {
        "name": "backlash",
        "axis": axis,
        "params": {
            "reversal_mm": mid,
            "reversal_at_start_mm": start,
            "reversal_at_end_mm": end,
            "growth_mm_per_m": (end - start) / (hi - lo) * 1000,
        },
        "physics": {"belt_ea_n": belt.ea_n, "carriage_friction_n": belt.friction_n},
    }
