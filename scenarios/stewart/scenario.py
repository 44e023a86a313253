"""Scenario ``stewart``: calibrate a Stewart platform's 42 leg parameters with tracker lengths.

1. The tracker's three stations (its rotation centre in holes M1-M3): trilateration from the
   lengths to three reference nests of known position (Eq. 1), uncertainty by Eq. 4-5.
2. A platform pose: the three reflectors multilaterated from the three stations, then the rigid
   transform of their known platform coordinates.
3. One-step: 60 poses with all six legs' readings; per leg, the seven unknowns by least squares;
   then the joint maximum likelihood over stations, poses and legs (every tracker length and leg
   reading weighted by its 1-sigma), whose covariance is reported and compared with the CRLB.
4. Two-step, per leg: the leg locked, the platform translated (orientation held) to nine
   non-coplanar places, three times at three orientations 10 degrees apart: the platform origin
   runs on a sphere of the leg's length about B - R r (Eq. 2); the three centres give r, then
   B and l.
5. Held-out poses: the pose computed from the legs' readings (forward kinematics) with the
   nominal and with the calibrated parameters, against the true pose.
"""

from __future__ import annotations

import dataclasses
import functools
from pathlib import Path

import numpy as np

from calibench.estimators.rotations import rotvec_to_matrix
from calibench.estimators.stewart.joint import (
    TrackerObservations,
    adjust_jointly,
    joint_information,
)
from calibench.estimators.stewart.kinematics import forward_kinematics_many, leg_conditions
from calibench.estimators.stewart.legs import LegCalibration, calibrate_legs, two_step_leg
from calibench.estimators.stewart.tracker import locate_stations, poses_from_lengths
from calibench.scenarios.harness import write_outputs
from calibench.scenarios.report import Check, Parameter, Report
from calibench.scenarios.run_recording import StewartRecordingPlan, check_plan, write_recording
from calibench.scenes.stewart import LEG_STROKE_MM, PLATFORM_KG, StewartGeometry
from calibench.sim.stewart import StewartSim, StewartTruth, stewart_poses

NAME = "stewart"
TOL_SIGMA = 5.0
LEG_PARAMS = ("a", "b", "c", "m", "n", "q", "l")


@dataclasses.dataclass(frozen=True)
class StewartConfig:
    geometry: StewartGeometry = StewartGeometry()
    truth: StewartTruth = StewartTruth()
    n_poses: int = 60
    n_holdout: int = 20
    translation_mm: float = 150.0  # the machine's working range about home
    rotation_deg: float = 10.0
    closure_limit_um: float = 0.1
    after_limit_um: float = 20.0
    # The instruments' 1-sigma as their datasheets state it, all the estimators are told (the
    # truth's *_noise_um is what the simulation draws): the tracker's lengths a + b * L(m) and the
    # legs' readings. The joint adjustment scales its covariance by the variance factor of its
    # residuals, so a datasheet off by a common factor leaves the reported std honest.
    stated_length_sigma_um: tuple = (0.3, 0.3)
    stated_reading_sigma_um: float = 1.0

    # [stewart.recording]: what DIR/recording.csv records and conceals (run_recording.py)
    recording: StewartRecordingPlan = StewartRecordingPlan()

    def __post_init__(self):
        check_plan(NAME, self.recording)
        if max(self.stated_length_sigma_um) <= 0:
            raise ValueError(
                "stated_length_sigma_um: the tracker's stated sigma a + b L needs a or b positive"
            )
        check_config(self)

    def length_sigma_mm(self, L_mm) -> np.ndarray:
        """The stated 1-sigma (mm) of the tracker's distances ``L_mm`` (mm)."""
        a, b = self.stated_length_sigma_um
        return (a + b * np.asarray(L_mm) / 1000) / 1000


# What the config's checks hold the set-up to (see check_config):
# a 1-sigma geometric error over 10 % of the platform's size is not a calibration error;
MAX_ERROR_FRACTION = 0.1
# a leg's give under the load, of its length: beyond it the legs are springs;
MAX_GIVE_FRACTION = 0.01
# the poses' turn about each axis: beyond it the platform lies on its side;
MAX_ROTATION_DEG = 90.0
# the legs' Jacobian's condition (rotations over the platform's radius): beyond it, near-singular
MAX_CONDITION = 1000.0


@functools.lru_cache(maxsize=16)
def _workspace(
    r: tuple, B: tuple, home_height_mm: float, translation_mm: float, rotation_deg: float
) -> tuple:
    """The legs at home (6,) and their Jacobian's condition there; the legs' shortest and longest
    and the largest condition over the poses' range (home +- translation along, +- rotation about
    each axis: the 3^6 corners and mid-points). Cached: a study's trials share their geometry, and
    the 729 poses cost a few milliseconds."""
    r, B = np.asarray(r, float).reshape(6, 3), np.asarray(B, float).reshape(6, 3)
    home_t = np.array([[0.0, 0.0, home_height_mm]])
    L_home, cond_home = leg_conditions(r, B, np.eye(3)[None], home_t)
    corners = np.array(np.meshgrid(*[[-1.0, 0.0, 1.0]] * 6)).reshape(6, -1).T  # (729, 6)
    R = rotvec_to_matrix(np.deg2rad(rotation_deg) * corners[:, 3:])
    L, cond = leg_conditions(r, B, R, home_t + translation_mm * corners[:, :3])
    return L_home[0], float(cond_home[0]), float(L.min()), float(L.max()), float(np.max(cond))


def check_config(c: StewartConfig) -> None:
    """What makes a Stewart set-up workable, checked before any simulation (BadInput, one line
    naming the key): enough poses for the legs' identification, a platform that is not singular
    and whose legs stay in their stroke over the poses, and errors that are errors."""
    from calibench.scenarios.config import bad, show
    from calibench.scenarios.report import BadInput

    g, t = c.geometry, c.truth
    need = len(LEG_PARAMS) + 1
    if c.n_poses < need:
        raise bad(
            f"{NAME}.n_poses",
            c.n_poses,
            f"at least {need}: each leg's one-step calibration solves {len(LEG_PARAMS)} unknowns "
            "(r, B, l) by "
            "least squares and scales their covariance by the residuals' variance, which needs "
            "one pose more",
        )
    if not c.rotation_deg <= MAX_ROTATION_DEG:
        raise bad(
            f"{NAME}.rotation_deg",
            c.rotation_deg,
            f"the poses turn by up to this about each axis: from 0 to {MAX_ROTATION_DEG:g} degrees",
        )
    # the platform at home: not singular, the legs within their stroke
    r, B = np.asarray(g.platform_hinges_mm, float), np.asarray(g.base_hinges_mm, float)
    size_p, size_b = (
        float(np.max(np.linalg.norm(r, axis=1))),
        float(np.max(np.linalg.norm(B, axis=1))),
    )
    L_home, cond_home, L_min, L_max, cond_max = _workspace(
        tuple(r.ravel()),
        tuple(B.ravel()),
        float(g.home_height_mm),
        float(c.translation_mm),
        float(c.rotation_deg),
    )
    lo, hi = LEG_STROKE_MM
    if not np.all((L_home >= lo) & (L_home <= hi)):
        raise bad(
            f"{NAME}.geometry.home_height_mm",
            g.home_height_mm,
            f"at home the legs are {L_home.min():.4g} to {L_home.max():.4g} mm long: the legs' "
            f"stroke is {lo:g} to {hi:g} mm (the scene's slides)",
        )
    if not cond_home <= MAX_CONDITION:
        raise BadInput(
            f"config: {NAME}.geometry: platform_hinges_mm and base_hinges_mm leave the platform "
            f"singular at home (the legs' Jacobian has condition number {cond_home:.3g}, at most "
            f"{MAX_CONDITION:g}): "
            "six legs pin its six degrees of freedom only from hinges spread around platform and "
            f"base (now out to {size_p:.4g} mm and {size_b:.4g} mm from their centres)"
        )
    # the poses' range: home +- translation_mm, +- rotation_deg about each axis
    what = (
        f"the poses (home_height_mm = {show(g.home_height_mm)}, +- translation_mm = "
        f"{show(c.translation_mm)} "
        f"along and +- rotation_deg = {show(c.rotation_deg)} about each axis)"
    )
    if not lo <= L_min <= L_max <= hi:
        raise BadInput(
            f"config: {NAME}: {what} take the legs from {L_min:.4g} to {L_max:.4g} mm: their "
            "stroke is "
            f"{lo:g} to {hi:g} mm (the scene's slides); a smaller translation_mm or rotation_deg"
        )
    if not cond_max <= MAX_CONDITION:
        raise BadInput(
            f"config: {NAME}: {what} come near a singularity (the legs' Jacobian's condition "
            "number "
            f"{cond_max:.3g}, at most {MAX_CONDITION:g}); a smaller translation_mm or rotation_deg"
        )
    # the injected geometric errors: errors, not a different machine
    size = min(size_p, size_b)
    for key in ("hinge_error_mm", "length_error_mm", "station_offset_mm"):
        v = getattr(t, key)
        if not v <= MAX_ERROR_FRACTION * size:
            raise bad(
                f"{NAME}.truth.{key}",
                v,
                f"a 1-sigma geometric error is at most {MAX_ERROR_FRACTION:.0%} of the platform's "
                "size (its "
                f"hinges {size:g} mm from the centre): from 0 to {MAX_ERROR_FRACTION * size:g} mm",
            )
    # the legs' give under the load (the payload and the platform's weight, shared by six legs
    # leaning as they do at home): a small error, not a spring
    v = r + [0.0, 0.0, g.home_height_mm] - B
    lean = float(np.min(np.abs(v[:, 2]) / np.linalg.norm(v, axis=1)))
    force = abs(t.payload_n + 9.81 * PLATFORM_KG) / (6 * max(lean, 1e-3))
    give = np.abs(np.asarray(t.leg_compliance_um_per_n, float)) * force / 1000
    if not np.all(give <= MAX_GIVE_FRACTION * L_home):
        most = MAX_GIVE_FRACTION * float(L_home.min()) * 1000 / force
        raise bad(
            f"{NAME}.truth.leg_compliance_um_per_n",
            t.leg_compliance_um_per_n,
            f"a leg would give {give.max():.4g} mm under the load (payload_n = {t.payload_n:g} "
            "and the "
            f"platform's weight, about {force:.4g} N a leg): at most {MAX_GIVE_FRACTION:.0%} of "
            f"its length, compliance from 0 to {most:.3g} um/N",
        )


def measure_stations(sim: StewartSim, config: StewartConfig):
    """The tracker at each station measures the three nests: the lengths (3 stations, 3 nests)
    mm, and the stations with their covariance (Eq. 1, 4-5) from the stated 1-sigma."""
    nests = sim.geometry.reference_nests_mm
    lengths = np.array([sim.distances_mm(s, nests) for s in range(3)])
    stations, cov = locate_stations(
        nests, lengths, config.length_sigma_mm(lengths), above=np.array([0, 0, 1.0])
    )
    return stations, cov, lengths


def run(config: StewartConfig, seed: int, fidelity: str, out_dir: Path, rrd: bool) -> Report:
    """Simulate the Stewart platform measured by a laser tracker's lengths; calibrate it from
    what its sensors recorded; compare with the truth.

    The arguments and the Report: :class:`calibench.scenarios.registry.Scenario`.
    """
    rng = np.random.default_rng(seed)
    g = config.geometry
    sim = StewartSim(g, config.truth, np.random.default_rng(rng.integers(2**63)))
    stations, station_cov, nest_lengths = measure_stations(sim, config)
    station_err = np.linalg.norm(stations - sim.stations, axis=1)

    # one-step data
    poses = stewart_poses(config.n_poses, rng, g, config.translation_mm, config.rotation_deg)
    readings, lengths = [], []
    unconverged = 0  # multilaterations, spheres and forward kinematics that ran out of iterations
    for R, t in poses:  # the draws in the machine's order: legs, then the tracker, pose by pose
        sim.set_pose(R, t)
        readings.append(sim.readings_mm())
        lengths.append(sim.distances_many_mm(sim.reflectors_mm()[:3]))
    meas_R, meas_t, ok = poses_from_lengths(
        g.reflectors_mm[:3],
        stations,
        np.array(lengths),
        config.length_sigma_mm(np.array(lengths)),
        np.array([R for R, _ in poses]),
        np.array([t for _, t in poses]),
    )
    unconverged += int(np.sum(~ok))
    readings = np.array(readings)
    # each equation's sigma: the reading plus what the pose's error does at the hinge (~1 um)
    sigma = np.full(len(poses), np.hypot(config.stated_reading_sigma_um, 1.0) / 1000)
    nominal = (g.platform_hinges_mm, g.base_hinges_mm, g.initial_lengths_mm)
    pipeline = calibrate_legs(meas_R, meas_t, readings, *nominal, sigma)
    # The sequential pipeline leaves information unused (the legs' readings say where the
    # platform is too, and every pose says where the stations are): finish with the joint
    # maximum likelihood over stations, poses and legs, whose covariance reaches the CRLB.
    a_um, b_um_per_m = config.stated_length_sigma_um
    obs = TrackerObservations(
        g.reference_nests_mm,
        nest_lengths,
        g.reflectors_mm,
        np.array(lengths),
        readings,
        (a_um / 1000, b_um_per_m / 1e6),
        config.stated_reading_sigma_um / 1000,
    )
    joint = adjust_jointly(
        obs,
        stations,
        meas_R,
        meas_t,
        np.array([c.r for c in pipeline]),
        np.array([c.B for c in pipeline]),
        np.array([c.l for c in pipeline]),
    )
    # the Cramer-Rao bound at the truth, from the simulation's own noise (not the datasheet's)
    a_um, b_um_per_m = config.truth.length_noise_um
    true_noise = dataclasses.replace(
        obs,
        length_sigma=(a_um / 1000, b_um_per_m / 1e6),
        reading_sigma=config.truth.reading_noise_um / 1000,
    )
    bound = np.sqrt(
        np.diag(
            joint_information(
                true_noise,
                sim.stations,
                np.array([R for R, _ in poses]),
                np.array([t for _, t in poses]),
                sim.r,
                sim.B,
                sim.l0,
            )
        )
    )
    legs = [
        LegCalibration(
            joint.r[i], joint.B[i], float(joint.l[i]), joint.std[7 * i : 7 * i + 7], joint.rms
        )
        for i in range(6)
    ]

    # two-step
    two_step = [two_step_experiment(sim, stations, i, config) for i in range(6)]
    unconverged += sum(c.unconverged for c in two_step)
    spheres = [list(zip(c.centres, c.radii, c.origins)) for c in two_step]

    # held-out poses: the pose from the readings, nominal vs calibrated
    hold = stewart_poses(config.n_holdout, rng, g, config.translation_mm, config.rotation_deg)
    err = {"before": [], "after": [], "two_step": []}
    one = (
        np.array([c.r for c in legs]),
        np.array([c.B for c in legs]),
        np.array([c.l for c in legs]),
    )
    two = (
        np.array([c.r for c in two_step]),
        np.array([c.B for c in two_step]),
        np.array([c.l for c in two_step]),
    )
    home = (np.eye(3), np.array([0, 0, g.home_height_mm]))
    reads = []
    for R, t in hold:
        sim.set_pose(R, t)
        reads.append(sim.readings_mm())
    R_hold, t_hold = np.array([R for R, _ in hold]), np.array([t for _, t in hold])
    true_hinges = np.einsum("nij,kj->nki", R_hold, g.platform_hinges_mm) + t_hold[:, None]
    for key, (r, B, l) in (("before", nominal), ("after", one), ("two_step", two)):
        Rf, tf, ok = forward_kinematics_many(l + np.array(reads), r, B, *home)
        unconverged += int(np.sum(~ok))
        # the pose's error seen at the nominal hinge points (position and turn together)
        hinges = np.einsum("nij,kj->nki", Rf, g.platform_hinges_mm) + tf[:, None]
        err[key] = list(np.linalg.norm(hinges - true_hinges, axis=2))
    rms = {k: float(np.sqrt(np.mean(np.square(v)))) * 1000 for k, v in err.items()}

    report = Report(scenario=NAME, seed=seed, fidelity="analytic")
    truth_vals = [np.r_[sim.r[i], sim.B[i], sim.l0[i]] for i in range(6)]
    for i, c in enumerate(legs):
        est = np.r_[c.r, c.B, c.l]
        for k, name in enumerate(LEG_PARAMS):
            report.parameters.append(
                Parameter(
                    f"leg{i + 1}_{name}",
                    "mm",
                    float(truth_vals[i][k]),
                    float(est[k]),
                    float(c.std[k]),
                    TOL_SIGMA * float(c.std[k]),
                    crlb=float(bound[7 * i + k]),
                )
            )
    predicted = np.array([np.sqrt(np.diag(c)) for c in station_cov]) * 1000
    report.checks += [
        Check(
            "loop_closure_um",
            sim.max_closure_um,
            config.closure_limit_um,
            note="largest gap between a leg's end and its platform hinge over every pose set",
        ),
        Check(
            "station_error_um",
            float(station_err.max() * 1000),
            float(5 * predicted.max() * np.sqrt(3)),
            note="largest station position error; limit 5 x its propagated 1-sigma (Eq. 4-5)",
        ),
        Check(
            "pose_rms_before_um",
            rms["before"],
            None,
            note=f"{config.n_holdout} held-out poses, nominal parameters",
        ),
        Check(
            "pose_rms_after_um",
            rms["after"],
            config.after_limit_um,
            note="held-out poses, one-step calibration",
        ),
        Check(
            "pose_rms_after_two_step_um",
            rms["two_step"],
            None,
            note="held-out poses, two-step calibration",
        ),
        # a solve that ran out of iterations would report its last iterate as if it were the answer
        Check(
            "solves_not_converged",
            float(sum(not c.converged for c in pipeline) + (not joint.converged) + unconverged),
            0.0,
            note="the six legs' one-step Gauss-Newton, the joint adjustment, the "
            "multilaterations, the two-step spheres and the held-out poses' forward kinematics",
        ),
    ]
    two_err = np.array([np.r_[c.r, c.B, c.l] for c in two_step]) - np.array(truth_vals)
    one_err = np.array([np.r_[c.r, c.B, c.l] for c in legs]) - np.array(truth_vals)
    report.info = {
        "compare_rms_error_mm": {
            "one_step": float(np.sqrt(np.mean(one_err**2))),
            "two_step": float(np.sqrt(np.mean(two_err**2))),
        },
        "two_step": {
            f"leg{i + 1}": dict(zip(LEG_PARAMS, map(float, np.r_[c.r, c.B, c.l])))
            for i, c in enumerate(two_step)
        },
        "station_error_um": (station_err * 1000).tolist(),
        "station_sigma_um": predicted.tolist(),
        "whitened_rms": joint.rms,
        "pipeline_rms_error_mm": float(
            np.sqrt(
                np.mean(
                    (np.array([np.r_[c.r, c.B, c.l] for c in pipeline]) - np.array(truth_vals)) ** 2
                )
            )
        ),
    }
    artifacts = dict(
        sim=sim,
        poses=poses,
        stations=stations,
        spheres=spheres,
        config=config,
        holdout_error_mm=err,
    )
    write_recording(out_dir, NAME, config, seed, report.info)
    return write_outputs(report, artifacts, out_dir, rrd, "calibench.scenarios.stewart")


def directions_across(u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit directions a, b (3,) across the unit vector ``u`` (3,), with a x b = u, by a
    formula: the null space of a rank-one matrix from an SVD is a basis LAPACK picks freely, and
    its pick differs between CPUs (the two-step's poses, hence its figures, moved by 10 %)."""
    e = np.eye(3)[
        np.argmin(np.abs(u))
    ]  # the axis farthest from u: the cross product is well scaled
    a = np.cross(u, e)
    a /= np.linalg.norm(a)
    return a, np.cross(u, a)


def two_step_experiment(sim: StewartSim, stations: np.ndarray, i: int, config: StewartConfig):
    """Lock leg i at its home length; translate the platform at three fixed orientations so the
    leg keeps its length, the tracker measuring each place; the two-step method's estimate from
    those lengths (:func:`calibench.estimators.stewart.legs.two_step_leg`)."""
    g = sim.geometry
    home_t = np.array([0, 0, g.home_height_mm])
    # the sphere's centre lies along the leg: a wide cap pins it, and wide turns between the
    # three orientations keep r from amplifying the centres' errors (by 1 / turn)
    orientations = [
        np.eye(3),
        rotvec_to_matrix(np.deg2rad([10.0, 0, 0])),
        rotvec_to_matrix(np.deg2rad([0, 10.0, 0])),
    ]
    sim.set_pose(np.eye(3), home_t)
    locked = sim.readings_mm()[i]
    L = sim.leg_lengths_mm()[i]
    places, lengths = [], []
    for R0 in orientations:
        c_true = sim.B[i] - R0 @ sim.r[i]  # the platform origin's sphere (truth drives the motion)
        u0 = (home_t - c_true) / np.linalg.norm(home_t - c_true)
        a, b = directions_across(u0)
        dirs = [u0] + [
            np.cos(cap) * u0 + np.sin(cap) * (np.cos(k) * a + np.sin(k) * b)
            for cap in (0.12, 0.24)
            for k in np.deg2rad([0, 90, 180, 270])
        ]
        targets, d = [c_true + L * dvec for dvec in dirs], []
        for t in targets:
            sim.set_pose(R0, t)
            d.append(sim.distances_many_mm(sim.reflectors_mm()[:3]))
        places.append(targets)
        lengths.append(d)
    lengths = np.array(lengths)
    return two_step_leg(
        g.reflectors_mm[:3],
        stations,
        lengths,
        config.length_sigma_mm(lengths),
        np.array(orientations),
        np.array(places),
        locked,
    )


def prior(config: StewartConfig, rng: np.random.Generator) -> StewartConfig:
    """The hinges' and lengths' errors are drawn by the simulator from the run's seed (hinges
    N(0, 0.4 mm), initial lengths N(0, 0.5 mm)): nothing more to draw here."""
    return config
