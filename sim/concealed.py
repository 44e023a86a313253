"""Blinded recordings with concealed effects: the proof set for ``calibench discover``.

Separate code from the candidate library (``estimators.effects``): the effects here are written
as the physics of a machine (a drive that lags on reversal, a pulley that runs out, a scale that
warms, a rail with a bump), realised on top of the MuJoCo twin's own motion. The truth goes to a
sealed manifest that ``discover`` never reads; only the suite opens it afterwards.

Kinds: stages (belt-stage, vision-stage): ``null``, ``backlash``, ``periodic``, ``thermal``,
``combined`` (backlash + periodic + thermal), ``bump`` (a local defect no candidate has),
``mixed`` (lost motion, a periodic error and thermal expansion all on one axis, the temperature
rising over the passes), ``elastic`` (belt stage: one axis's belt elastic against the carriage's
friction, by MuJoCo's tendons: lost motion that grows along the travel); the arm (any description; the seed's arm CMM and the UR10 in the suite): ``null``, ``eccentricity``
(one joint's encoder), ``thermal`` (the links' growth), ``compliance`` (joints giving way under
gravity, by MuJoCo's physics); the probe scanner: ``null``, ``runout`` (the table's radial error
motion), ``eccentricity`` (the table encoder's), ``scale`` (the probe's), ``bump`` (a nick in the
plate's wall), ``combined`` (runout, eccentricity and scale); the Stewart platform: ``null``,
``thermal`` (a leg's growth), ``backlash`` (a leg's lost motion), ``pitch`` (a leg's screw),
``compliance`` (the legs shortened by their axial loads, by MuJoCo's statics).
"""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import numpy as np

from calibench.errors import BadInput
from calibench.recordings import ArmRecording, ScannerRecording, StageRecording, StewartRecording
from calibench.sim.replay import replay_stage
from calibench.sim.stage_drive import travel_direction

SCANNER_KINDS = ("null", "runout", "eccentricity", "scale", "bump", "combined")
STEWART_KINDS = ("null", "thermal", "backlash", "pitch", "compliance")
STAGE_KINDS = ("null", "backlash", "periodic", "thermal", "combined", "bump", "mixed", "elastic")
ARM_KINDS = ("null", "eccentricity", "thermal", "compliance", "transmission")
REFERENCE_NOISE_UM = 1.0  # the reference instrument (interferometer / microscope), 1-sigma
PASS_OFFSET_UM = 0.3  # each pass's own offset: correlated noise that must not become a term


@dataclasses.dataclass(frozen=True)
class StagePlan:
    """ISO 230-2 style lines: along X at three Y levels and along Y at three X levels, each
    forward then backward, ``passes`` times; ``step_mm`` fine enough for a 30 mm period."""

    travel_mm: tuple[float, float]
    step_mm: float
    passes: int = 4
    seconds_per_station: float = 3.0


PLANS = {
    "belt-stage": StagePlan((500.0, 400.0), 6.5),
    "vision-stage": StagePlan((300.0, 200.0), 4.5),
}


def stage_commands(plan: StagePlan) -> dict:
    """Commanded positions (n,) x, y, with pass id and the direction each axis last moved."""
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


def stage_recording(scenario: str, kind: str, seed: int) -> tuple[StageRecording, dict]:
    """A blinded recording of ``kind`` and its sealed truth (effects with their parameters)."""
    if kind not in STAGE_KINDS:
        raise ValueError(f"unknown kind {kind!r}")
    rng = np.random.default_rng(seed)
    plan = PLANS[scenario]
    c = stage_commands(plan)
    x, y, n = c["x"], c["y"], len(c["x"])
    effects = []
    if kind == "elastic":
        if scenario != "belt-stage":
            raise ValueError("an elastic belt is the belt stage's")
        a = str(rng.choice(["x", "y"]))
        pos, effect = _elastic_belt(a, rng, x, y)
        effects.append(effect)
    else:
        pos = replay_stage(scenario, x, y)
    err = np.zeros((n, 2))
    # the as-built machine differs smoothly from the twin (the scene's model absorbs this)
    u, v = x / plan.travel_mm[0], y / plan.travel_mm[1]
    for k in range(2):
        err[:, k] += rng.normal(0, 0.02, 6) @ np.stack([np.ones(n), u, v, u * u, u * v, v * v])
    T = 20.0 + np.cumsum(rng.normal(0, 0.002, n))  # a quiet room: the logged temperature wanders
    wanted = {
        "combined": ("backlash", "periodic", "thermal"),
        "mixed": ("backlash", "periodic", "thermal"),
    }.get(kind, (kind,))
    axis_of = {"x": 0, "y": 1}
    pick = [str(a) for a in rng.permutation(["x", "y"])]
    if "backlash" in wanted:
        a = pick[0]
        B = rng.uniform(5, 15) / 1000
        err[:, axis_of[a]] += B / 2 * c[f"dir_{a}"]
        effects.append({"name": "backlash", "axis": a, "params": {"reversal_mm": B}})
    if "periodic" in wanted:
        a = pick[1] if kind == "combined" else pick[0]
        P, A, ph = rng.uniform(30, 100), rng.uniform(4, 10) / 1000, rng.uniform(0, 2 * np.pi)
        pos_a = x if a == "x" else y
        err[:, axis_of[a]] += A * np.sin(2 * np.pi * pos_a / P + ph)
        effects.append(
            {"name": "periodic", "axis": a, "params": {"period_mm": P, "amplitude_mm": A}}
        )
    if "thermal" in wanted:
        rise, tau = rng.uniform(2, 5), c["t_s"][-1] / rng.uniform(1.5, 3)
        T = T + rise * (1 - np.exp(-c["t_s"] / tau))
        k = rng.uniform(10, 25)  # ppm/K: the scale's mismatch with the part (aluminium vs glass)
        for a, u_a in (("x", x), ("y", y)):
            if kind == "mixed" and a != pick[0]:  # all three on one axis
                continue
            err[:, axis_of[a]] += k * 1e-6 * (T - T[0]) * u_a
            effects.append(
                {
                    "name": "thermal_expansion",
                    "axis": a,
                    "params": {"ppm_per_k": k},
                    "temperature_rise_k": rise,
                }
            )
    if kind == "bump":
        x0, w, h = (
            rng.uniform(0.2, 0.8) * plan.travel_mm[0],
            rng.uniform(8, 15),
            rng.uniform(8, 15) / 1000,
        )
        err[:, 1] += h * np.exp(
            -0.5 * ((x - x0) / w) ** 2
        )  # the X rail's bump lifts the carriage sideways
        effects.append(
            {
                "name": "nonsmooth",
                "axis": "y",
                "params": {"x_mm": x0, "width_mm": w, "height_mm": h},
            }
        )
    run = c["run"].astype(int)
    err += rng.normal(0, PASS_OFFSET_UM / 1000, (plan.passes, 2))[run]
    err += rng.normal(0, REFERENCE_NOISE_UM / 1000, (n, 2))
    meas = pos + err
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
    return rec, {
        "scenario": scenario,
        "kind": kind,
        "seed": seed,
        "effects": effects,
        "noise_um": REFERENCE_NOISE_UM,
    }


def _elastic_belt(
    axis: str, rng: np.random.Generator, x: np.ndarray, y: np.ndarray
) -> tuple[np.ndarray, dict]:
    """The belt stage's twin with ``axis``'s belt elastic (EA 25-50 kN against 2-5 N of carriage
    friction) at the commands, (n, 2) mm, and the effect's truth: the reversal measured on the
    elastic belt itself (MuJoCo), approached from either side at the ends and middle of the travel."""
    import dataclasses as dc

    from calibench.scenes.belt_stage import BeltStageGeometry
    from calibench.sim.belt_stage import BeltStageTruth
    from calibench.sim.stage_drive import BeltDrive, ElasticBelt

    belt = BeltDrive(ea_n=rng.uniform(25e3, 50e3), friction_n=rng.uniform(2.0, 5.0))
    truth = dc.replace(BeltStageTruth(), **{f"belt_{axis}": belt})
    pos = replay_stage("belt-stage", x, y, truth=truth)
    u = x if axis == "x" else y
    travel = BeltStageGeometry().travel_mm["xy".index(axis)]

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


def arm_recording(
    kind: str,
    seed: int,
    n: int = 300,
    noise_um: float = 10.0,
    arm: str = "arm-cmm",
    joint: int | None = None,
    harmonic: float | None = None,
    phase_rad: float | None = None,
    amplitude_urad: float | None = None,
) -> tuple[ArmRecording, dict]:
    """A blinded arm recording: the twin with its default as-built errors (Table 1 for the seed's
    arm), probed at ``n`` postures by a reference of ``noise_um`` 1-sigma per coordinate that
    reports in its own frame (a tracker's), with the concealed effect of ``kind``:

    - ``eccentricity``: one joint's encoder disc off-centre (the reading is off once per turn);
    - ``transmission``: one joint's gear train off periodically, 8-40 cycles per turn (not a
      whole number: a reduction's ratio);
    - ``thermal``: the links and tool grow with the logged temperature;
    - ``compliance``: the two most loaded joints given way under gravity (stiffness drawn so the
      largest sag is 100-300 urad), the links settled where MuJoCo's physics puts them.

    ``joint``: the eccentric (or geared) joint; ``harmonic``, ``phase_rad``, ``amplitude_urad``: the
    gear's (default: each drawn; given, sessions of one gear train can be recorded).
    """
    from calibench.scenes.arm_cmm import load_arm
    from calibench.sim.arm_cmm import ArmSim, ArmTruth

    if kind not in ARM_KINDS:
        raise ValueError(f"unknown kind {kind!r} (known: {', '.join(ARM_KINDS)})")
    rng = np.random.default_rng(seed)
    description = load_arm(arm)
    N = description.n_joints
    truth = ArmTruth()
    sim = ArmSim(description, truth)
    q = sim.random_postures(n, rng)
    t = np.arange(n) * 20.0
    T = 20.0 + np.cumsum(rng.normal(0, 0.002, n))
    q_read = q + rng.normal(0, truth.encoder_noise_urad * 1e-6, q.shape)
    effects = []
    if kind == "eccentricity":
        j, A, ph = (
            int(rng.integers(1, N + 1)),
            rng.uniform(300, 600) * 1e-6,
            rng.uniform(0, 2 * np.pi),
        )
        j = joint or j
        q_read[:, j - 1] += A * np.sin(q[:, j - 1] + ph)
        effects.append(
            {
                "name": "encoder_eccentricity",
                "axis": "xyz",
                "params": {"joint": j, "amplitude_urad": A * 1e6, "phase_rad": ph},
            }
        )
    if kind == "transmission":
        j = joint or int(rng.integers(1, N + 1))
        h, A, ph = rng.uniform(8, 40), rng.uniform(150, 300) * 1e-6, rng.uniform(0, 2 * np.pi)
        h = h if harmonic is None else harmonic
        ph = ph if phase_rad is None else phase_rad
        A = A if amplitude_urad is None else amplitude_urad * 1e-6
        q_read[:, j - 1] += A * np.sin(h * q[:, j - 1] + ph)
        effects.append(
            {
                "name": "transmission",
                "axis": "xyz",
                "params": {
                    "joint": j,
                    "harmonics": [h],
                    "amplitude_urad": [A * 1e6],
                    "phase_rad": ph,
                },
            }
        )
    if kind == "thermal":
        rise, k = rng.uniform(2, 5), rng.uniform(10, 25)
        T = T + rise * (1 - np.exp(-t / (t[-1] / 2)))
        effects.append(
            {
                "name": "thermal_expansion",
                "axis": "xyz",
                "params": {"ppm_per_k": k},
                "temperature_rise_k": rise,
            }
        )
        xyz = np.empty((n, 3))
        base = sim.delta
        lengths = np.zeros(5 * N + 3)
        lengths[0 : 5 * N : 5] = np.asarray(description.a_mm) + base[0 : 5 * N : 5]
        lengths[1 : 5 * N : 5] = np.asarray(description.d_mm) + base[1 : 5 * N : 5]
        lengths[5 * N :] = np.asarray(description.tool_mm) + base[5 * N :]
        for i in range(n):  # each posture on the arm as long as it then was
            delta = base + k * 1e-6 * (T[i] - T[0]) * lengths
            xyz[i] = ArmSim(description, dataclasses.replace(truth, delta=tuple(delta))).probe_mm(
                q[i : i + 1]
            )[0]
    elif kind == "compliance":
        if not description.has_masses:
            raise BadInput(f"the arm {description.name} has no masses: no compliance under gravity")
        tau = np.abs(sim.gravity_torques(q)).max(axis=0)
        joints = np.sort(np.argsort(-tau)[:2]) + 1
        k = np.full(N, np.inf)
        for j in joints:
            k[j - 1] = tau[j - 1] / (rng.uniform(100, 300) * 1e-6)
            effects.append(
                {
                    "name": "joint_compliance",
                    "axis": "xyz",
                    "params": {"joint": int(j), "urad_per_nm": 1e6 / k[j - 1]},
                }
            )
        sim = ArmSim(description, dataclasses.replace(truth, stiffness_nm_per_rad=tuple(k)))
        xyz = sim.probe_mm(q)  # MuJoCo's gravity torques, the links at their equilibrium
    else:
        xyz = sim.probe_mm(q)
    R, p = truth.tracker2base()
    xyz = (xyz - p) @ R  # the instrument reports in its own frame
    xyz = xyz + rng.normal(0, noise_um / 1000, xyz.shape)
    return (
        ArmRecording(q_read, xyz, t, np.round(T, 3)),
        {
            "scenario": "arm-cmm",
            "arm": description.name,
            "kind": kind,
            "seed": seed,
            "effects": effects,
            "noise_um": noise_um,
        },
    )


def scanner_recording(kind: str, seed: int, turns: int = 4) -> tuple[ScannerRecording, dict]:
    """A blinded probe-scanner recording: ``turns`` turns over the calibration plate, the rail
    as built (its d, dL, alpha0 and the plate's clamping drawn about the design), each reading
    MuJoCo's ray at the table's true angle, with the concealed effect of ``kind``:

    - ``runout``: the table's bearing moves radially along the rail, a whole number of times
      per turn (2-9, not 4 or 8), 3-8 um: the stylus starts that much further out;
    - ``eccentricity``: the encoder's disc off-centre, 150-400 urad: the table stands short of
      what the encoder reads;
    - ``scale``: the probe's linear encoder reads 0.1-0.3 % long;
    - ``bump``: a nick in the plate's wall 10-25 um deep, 0.5-1.5 deg wide;
    - ``combined``: runout, eccentricity and scale together.
    """
    from calibench.scenes.probe_scanner import ProbeScannerGeometry
    from calibench.sim.probe_scanner import ProbeScannerSim, ProbeScannerTruth

    if kind not in SCANNER_KINDS:
        raise ValueError(f"unknown kind {kind!r} (known: {', '.join(SCANNER_KINDS)})")
    rng = np.random.default_rng(seed)
    g = ProbeScannerGeometry()
    truth = ProbeScannerTruth(
        d_mm=rng.uniform(7.6, 8.4),
        dL_mm=rng.uniform(2.7, 3.3),
        alpha0_rad=rng.uniform(0.30, 0.40),
        plate_centre_mm=tuple(float(v) for v in rng.normal(0, 0.1, 2)),
    )
    sim = ProbeScannerSim(g, truth)
    m = g.samples_per_turn
    nominal = np.tile(np.arange(m) * 2 * np.pi / m, turns)
    turn = np.repeat(np.arange(turns), m)
    wanted = {"combined": ("runout", "eccentricity", "scale")}.get(kind, (kind,))
    effects = []
    true_theta = nominal + rng.normal(0, np.deg2rad(truth.angle_jitter_deg), len(nominal))
    if "eccentricity" in wanted:
        A, ph = rng.uniform(150, 400) * 1e-6, rng.uniform(0, 2 * np.pi)
        true_theta -= A * np.sin(nominal + ph)  # the encoder reads A sin ahead of the table
        effects.append(
            {"name": "encoder_eccentricity", "axis": "rho", "params": {"amplitude_urad": A * 1e6}}
        )
    rho = sim.exact_rho("plate", true_theta)
    if "runout" in wanted:
        # not 4 or 8: a square artefact cannot show a fourfold runout (discover says so)
        k, A, ph = (
            int(rng.choice([2, 3, 5, 6, 7, 9])),
            rng.uniform(3, 8) / 1000,
            rng.uniform(0, 2 * np.pi),
        )
        rho -= A * np.sin(k * true_theta + ph)
        effects.append(
            {"name": "runout", "axis": "rho", "params": {"harmonic": k, "amplitude_mm": A}}
        )
    if kind == "bump":
        th0, w, h = rng.uniform(0, 360), rng.uniform(0.5, 1.5), rng.uniform(10, 25) / 1000
        dist = (np.degrees(nominal) - th0 + 180) % 360 - 180
        rho += h * np.exp(-0.5 * (dist / w) ** 2)  # the stylus drops into the nick
        effects.append(
            {
                "name": "nonsmooth",
                "axis": "rho",
                "params": {"theta_deg": th0, "width_deg": w, "depth_mm": h},
            }
        )
    if "scale" in wanted:
        s = rng.uniform(1000, 3000)
        rho *= 1 + s * 1e-6
        effects.append({"name": "scale", "axis": "rho", "params": {"ppm": s}})
    q = truth.quantum_um / 1000
    rho = np.round((rho + rng.normal(0, truth.probe_noise_um / 1000, len(rho))) / q) * q
    t = np.arange(len(rho)) * 10.0 / m  # ten seconds a turn
    rec = ScannerRecording(
        turn, nominal, rho, t, np.round(20.0 + np.cumsum(rng.normal(0, 1e-3, len(rho))), 3)
    )
    noise = float(np.hypot(truth.probe_noise_um, truth.quantum_um / np.sqrt(12)))
    return rec, {
        "scenario": "probe-scanner",
        "kind": kind,
        "seed": seed,
        "effects": effects,
        "noise_um": noise,
    }


# The Stewart scenario's default working range about home (its StewartConfig's), fixed here: the
# proof set does not move with the scenario's config.
STEWART_TRANSLATION_MM = 150.0
STEWART_ROTATION_DEG = 10.0


def stewart_poses(
    n: int,
    rng: np.random.Generator,
    geometry,
    translation_mm: float = STEWART_TRANSLATION_MM,
    rotation_deg: float = STEWART_ROTATION_DEG,
) -> list[tuple[np.ndarray, np.ndarray]]:
    """Random poses of a Stewart platform within a working range about its home.

    Parameters
    ----------
    n : int
        How many poses.
    rng : numpy.random.Generator
        The draws, per pose a rotation vector then a translation.
    geometry : calibench.scenes.stewart.StewartGeometry
        The machine; its ``home_height_mm`` is the home's height.
    translation_mm : float
        Each coordinate of the origin drawn uniformly within home +- this, mm.
    rotation_deg : float
        Each component of the rotation vector drawn uniformly within +- this, deg.

    Returns
    -------
    list of (ndarray, ndarray)
        ``n`` poses: R (3, 3) the platform's orientation and t (3,) its origin, mm.
    """
    home = np.array([0, 0, geometry.home_height_mm])
    rot = np.deg2rad(rotation_deg)
    return [
        (
            _rotvec_to_matrix(rng.uniform(-rot, rot, 3)),
            home + rng.uniform(-1, 1, 3) * translation_mm,
        )
        for _ in range(n)
    ]


def _rotvec_to_matrix(w: np.ndarray) -> np.ndarray:
    """Rotation vector (3,) rad -> matrix (3, 3), by Rodrigues' formula on scalars (the same
    arithmetic as the scenario's poses, so the recordings stay what they were)."""
    x, y, z = (float(v) for v in w)
    theta = math.sqrt(x * x + y * y + z * z)
    if theta < 1e-8:
        a, b = 1.0 - theta**2 / 6, 0.5 - theta**2 / 24
    else:
        a, b = math.sin(theta) / theta, 2 * (math.sin(0.5 * theta) / theta) ** 2
    return np.array(
        [
            [1 - b * (y * y + z * z), b * x * y - a * z, b * x * z + a * y],
            [b * x * y + a * z, 1 - b * (x * x + z * z), b * y * z - a * x],
            [b * x * z - a * y, b * y * z + a * x, 1 - b * (x * x + y * y)],
        ]
    )


def stewart_recording(kind: str, seed: int, n_poses: int = 100) -> tuple[StewartRecording, dict]:
    """A blinded Stewart recording: ``n_poses`` poses visited, then visited again in reverse
    order (so every leg approaches each pose both ways), a payload of 0, 500 or 1000 N on the
    platform in turn, the platform as built (hinge errors of the scenario's size), the tracker
    in a frame of its own measuring three reflectors (2 um per coordinate), the legs' readings
    1 um, with the concealed effect of ``kind``:

    - ``thermal``: one leg grows 10-25 ppm/K, the temperature rising 2-5 K;
    - ``backlash``: one leg's drive loses 5-15 um on reversal;
    - ``pitch``: one leg's screw is off periodically, lead 4-12 mm, 3-8 um;
    - ``compliance``: every leg gives 0.02-0.05 um per N (each within 5 % of the others) of the
      axial force MuJoCo's statics put on it.
    """
    from scipy.spatial.transform import Rotation

    from calibench.scenes.stewart import StewartGeometry
    from calibench.sim.stewart import StewartSim, StewartTruth

    if kind not in STEWART_KINDS:
        raise ValueError(f"unknown kind {kind!r} (known: {', '.join(STEWART_KINDS)})")
    rng = np.random.default_rng(seed)
    g = StewartGeometry()
    sim = StewartSim(g, StewartTruth(), rng)
    poses = stewart_poses(n_poses, rng, g)
    poses = poses + poses[::-1]
    n = len(poses)
    load = 500.0 * (np.arange(n) % 3)
    L = np.empty((n, 6))
    force = np.zeros((n, 6))
    for k, (R, t) in enumerate(poses):
        sim.set_pose(R, t)
        L[k] = sim.leg_lengths_mm()
        if kind == "compliance":
            force[k] = sim.leg_forces_n(R, t, load[k])
    step = np.diff(np.vstack([L[:1] - 1.0, L]), axis=0)  # homed from below
    direction = np.sign(step)
    t_s = np.arange(n) * 30.0
    T = 20.0 + np.cumsum(rng.normal(0, 0.002, n))
    readings = L - sim.l0
    leg = int(rng.integers(1, 7))
    effects = []
    if kind == "thermal":
        rise, k = rng.uniform(2, 5), rng.uniform(10, 25)
        T = T + rise * (1 - np.exp(-t_s / (t_s[-1] / 2)))
        readings[:, leg - 1] -= k * 1e-6 * (T - T[0]) * L[:, leg - 1]
        effects.append(
            {"name": "thermal_expansion", "axis": "legs", "params": {"leg": leg, "ppm_per_k": k}}
        )
    if kind == "backlash":
        B = rng.uniform(5, 15) / 1000
        readings[:, leg - 1] += B / 2 * direction[:, leg - 1]
        effects.append(
            {"name": "backlash", "axis": "legs", "params": {"leg": leg, "reversal_mm": B}}
        )
    if kind == "pitch":
        P, A, ph = rng.uniform(4, 12), rng.uniform(3, 8) / 1000, rng.uniform(0, 2 * np.pi)
        readings[:, leg - 1] += A * np.sin(2 * np.pi * L[:, leg - 1] / P + ph)
        effects.append(
            {
                "name": "periodic",
                "axis": "legs",
                "params": {"leg": leg, "period_mm": P, "amplitude_mm": A},
            }
        )
    if kind == "compliance":
        c = rng.uniform(0.02, 0.05)
        readings += (
            c * (1 + 0.05 * rng.standard_normal(6)) * 1e-3 * force
        )  # the screw reads what the leg gave
        effects.append({"name": "leg_compliance", "axis": "legs", "params": {"um_per_n": c}})
    readings += rng.normal(0, 1e-3, readings.shape)
    # the tracker's frame: turned about the vertical and set beside the machine
    R_tr = Rotation.from_rotvec(
        np.r_[rng.normal(0, 0.01, 2), rng.uniform(-np.pi, np.pi)]
    ).as_matrix()
    t_tr = np.r_[rng.uniform(1500, 3000), rng.uniform(-1000, 1000), rng.uniform(-800, 0)]
    R_meas, t_meas = np.empty((n, 3, 3)), np.empty((n, 3))
    for k, (R, t) in enumerate(poses):
        world = g.reflectors_mm @ R.T + t
        seen = (world @ R_tr.T + t_tr) + rng.normal(0, 2e-3, world.shape)
        # the tracker's own pose solution (scipy's Kabsch, not the estimators')
        c_seen, c_refl = seen.mean(axis=0), g.reflectors_mm.mean(axis=0)
        R_meas[k] = Rotation.align_vectors(seen - c_seen, g.reflectors_mm - c_refl)[0].as_matrix()
        t_meas[k] = c_seen - R_meas[k] @ c_refl
    rec = StewartRecording(
        np.round(readings, 6), R_meas, t_meas, t_s, np.round(T, 3), direction, load
    )
    # per leg: the reading's 1 um and the tracker's pose (its reflectors' 2 um, levered out to the
    # hinges) together, as the repeats show it
    return rec, {
        "scenario": "stewart",
        "kind": kind,
        "seed": seed,
        "effects": effects,
        "noise_um": 2.3,
    }


def write_blinded(out_dir: Path, name: str, recording, manifest: dict) -> Path:
    """``name``.csv for discover; the truth sealed in ``name``.manifest.json beside it."""
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    path = out_dir / f"{name}.csv"
    recording.to_csv(path)
    (out_dir / f"{name}.manifest.json").write_text(json.dumps(manifest, indent=1) + "\n")
    return path
