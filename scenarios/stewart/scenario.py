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
from pathlib import Path

import numpy as np

from calibench.estimators.rotations import rotvec_to_matrix
from calibench.estimators.stewart.adjustment import (
    JointCalibration,
    TrackerObservations,
    adjust_jointly,
    joint_information,
)
from calibench.estimators.stewart.kinematics import forward_kinematics_many
from calibench.estimators.stewart.legs import LegCalibration, calibrate_legs, two_step_leg
from calibench.estimators.stewart.tracker import locate_stations, poses_from_lengths
from calibench.scenarios.harness import write_outputs
from calibench.scenarios.report import Check, Parameter, Report
from calibench.scenarios.run_recording import StewartRecordingPlan, check_plan, write_recording
from calibench.scenarios.stewart import NAME
from calibench.scenarios.stewart.checks import check_config
from calibench.scenes.stewart import StewartGeometry
from calibench.sim.stewart import StewartSim, StewartTruth, stewart_poses

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


def measure_stations(sim: StewartSim, config: StewartConfig):
    """The tracker at each station measures the three nests: the lengths (3 stations, 3 nests)
    mm, and the stations with their covariance (Eq. 1, 4-5) from the stated 1-sigma."""
    nests = sim.geometry.reference_nests_mm
    lengths = np.array([sim.distances_mm(s, nests) for s in range(3)])
    stations, cov = locate_stations(
        nests, lengths, config.length_sigma_mm(lengths), above=np.array([0, 0, 1.0])
    )
    return stations, cov, lengths


@dataclasses.dataclass(frozen=True)
class OneStepData:
    """The one-step experiment's data at its n poses.

    Attributes
    ----------
    R, t_mm : ndarray
        (n, 3, 3), (n, 3) the true poses.
    readings_mm : ndarray
        (n, 6) the legs' readings.
    lengths_mm : ndarray
        (n, 3, 3) the tracker's lengths, station by reflector.
    meas_R, meas_t_mm : ndarray
        (n, 3, 3), (n, 3) the poses multilaterated from the lengths.
    poses : list of (ndarray, ndarray)
        The n true poses as drawn, (R, t).
    unconverged : int
        Multilaterations that ran out of iterations.
    """

    R: np.ndarray
    t_mm: np.ndarray
    readings_mm: np.ndarray
    lengths_mm: np.ndarray
    meas_R: np.ndarray
    meas_t_mm: np.ndarray
    unconverged: int
    poses: list


def one_step_data(
    sim: StewartSim, rng: np.random.Generator, config: StewartConfig, stations: np.ndarray
) -> OneStepData:
    """The platform at ``config.n_poses`` poses drawn from ``rng``: the legs' readings and the
    tracker's lengths from the ``stations`` (3, 3) mm (the draws in the machine's order: legs,
    then the tracker, pose by pose), and each pose multilaterated from them."""
    g = sim.geometry
    poses = stewart_poses(config.n_poses, rng, g, config.translation_mm, config.rotation_deg)
    readings, lengths = [], []
    for R, t in poses:
        sim.set_pose(R, t)
        readings.append(sim.readings_mm())
        lengths.append(sim.distances_many_mm(sim.reflectors_mm()[:3]))
    R_true, t_true = np.array([R for R, _ in poses]), np.array([t for _, t in poses])
    meas_R, meas_t, ok = poses_from_lengths(
        g.reflectors_mm[:3],
        stations,
        np.array(lengths),
        config.length_sigma_mm(np.array(lengths)),
        R_true,
        t_true,
    )
    return OneStepData(
        R_true,
        t_true,
        np.array(readings),
        np.array(lengths),
        meas_R,
        meas_t,
        int(np.sum(~ok)),
        poses,
    )


def joint_calibration(
    sim: StewartSim,
    config: StewartConfig,
    stations: np.ndarray,
    nest_lengths: np.ndarray,
    data: OneStepData,
) -> tuple[list[LegCalibration], list[LegCalibration], JointCalibration, np.ndarray]:
    """Per leg, the seven unknowns by least squares from the multilaterated poses (the
    sequential pipeline), then the joint maximum likelihood over stations, poses and legs from
    there: the sequential pipeline leaves information unused (the legs' readings say where the
    platform is too, and every pose says where the stations are); the joint one's covariance
    reaches the CRLB.

    Returns
    -------
    pipeline : list of LegCalibration
        6, the sequential pipeline's.
    legs : list of LegCalibration
        6, the joint adjustment's.
    joint : JointCalibration
        The joint adjustment.
    bound : ndarray
        (42,) the Cramer-Rao bound of the legs' parameters at the truth, from the simulation's
        own noise (not the datasheet's), mm.
    """
    g = config.geometry
    # each equation's sigma: the reading plus what the pose's error does at the hinge (~1 um)
    sigma = np.full(len(data.R), np.hypot(config.stated_reading_sigma_um, 1.0) / 1000)
    nominal = (g.platform_hinges_mm, g.base_hinges_mm, g.initial_lengths_mm)
    pipeline = calibrate_legs(data.meas_R, data.meas_t_mm, data.readings_mm, *nominal, sigma)
    a_um, b_um_per_m = config.stated_length_sigma_um
    obs = TrackerObservations(
        g.reference_nests_mm,
        nest_lengths,
        g.reflectors_mm,
        data.lengths_mm,
        data.readings_mm,
        (a_um / 1000, b_um_per_m / 1e6),
        config.stated_reading_sigma_um / 1000,
    )
    joint = adjust_jointly(
        obs,
        stations,
        data.meas_R,
        data.meas_t_mm,
        np.array([c.r for c in pipeline]),
        np.array([c.B for c in pipeline]),
        np.array([c.l for c in pipeline]),
    )
    a_um, b_um_per_m = config.truth.length_noise_um
    true_noise = dataclasses.replace(
        obs,
        length_sigma=(a_um / 1000, b_um_per_m / 1e6),
        reading_sigma=config.truth.reading_noise_um / 1000,
    )
    information = joint_information(
        true_noise, sim.stations, data.R, data.t_mm, sim.r, sim.B, sim.l0
    )
    bound = np.sqrt(np.diag(information))
    legs = [
        LegCalibration(
            joint.r[i], joint.B[i], float(joint.l[i]), joint.std[7 * i : 7 * i + 7], joint.rms
        )
        for i in range(6)
    ]
    return pipeline, legs, joint, bound


def holdout_errors(
    sim: StewartSim, rng: np.random.Generator, config: StewartConfig, models: dict
) -> tuple[dict[str, list[np.ndarray]], int]:
    """At ``config.n_holdout`` fresh poses drawn from ``rng``, the pose computed from the legs'
    readings (forward kinematics) with each of the ``models`` (name -> (r (6, 3), B (6, 3),
    l (6,)) mm), against the true pose: the error seen at the nominal hinge points (position
    and turn together).

    Returns
    -------
    errors : dict of str to list of ndarray
        Per model, per pose the six hinges' errors (6,) mm.
    unconverged : int
        Forward kinematics that ran out of iterations.
    """
    g = sim.geometry
    hold = stewart_poses(config.n_holdout, rng, g, config.translation_mm, config.rotation_deg)
    home = (np.eye(3), np.array([0, 0, g.home_height_mm]))
    reads = []
    for R, t in hold:
        sim.set_pose(R, t)
        reads.append(sim.readings_mm())
    R_hold, t_hold = np.array([R for R, _ in hold]), np.array([t for _, t in hold])
    true_hinges = np.einsum("nij,kj->nki", R_hold, g.platform_hinges_mm) + t_hold[:, None]
    errors: dict[str, list[np.ndarray]] = {}
    unconverged = 0
    for key, (r, B, l) in models.items():
        Rf, tf, ok = forward_kinematics_many(l + np.array(reads), r, B, *home)
        unconverged += int(np.sum(~ok))
        hinges = np.einsum("nij,kj->nki", Rf, g.platform_hinges_mm) + tf[:, None]
        errors[key] = list(np.linalg.norm(hinges - true_hinges, axis=2))
    return errors, unconverged


def leg_array(legs: list) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The legs' calibrations (6 of r, B, l) as arrays: r (6, 3), B (6, 3), l (6,) mm."""
    return (
        np.array([c.r for c in legs]),
        np.array([c.B for c in legs]),
        np.array([c.l for c in legs]),
    )


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

    data = one_step_data(sim, rng, config, stations)
    # multilaterations, spheres and forward kinematics that ran out of iterations
    unconverged = data.unconverged
    pipeline, legs, joint, bound = joint_calibration(sim, config, stations, nest_lengths, data)

    two_step = [two_step_experiment(sim, stations, i, config) for i in range(6)]
    unconverged += sum(c.unconverged for c in two_step)
    spheres = [list(zip(c.centres, c.radii, c.origins)) for c in two_step]

    nominal = (g.platform_hinges_mm, g.base_hinges_mm, g.initial_lengths_mm)
    models = {"before": nominal, "after": leg_array(legs), "two_step": leg_array(two_step)}
    err, missed = holdout_errors(sim, rng, config, models)
    unconverged += missed
    rms = {k: float(np.sqrt(np.mean(np.square(v)))) * 1000 for k, v in err.items()}

    report = Report(scenario=NAME, seed=seed, fidelity="analytic")
    truth_vals = [np.r_[sim.r[i], sim.B[i], sim.l0[i]] for i in range(6)]
    report.parameters += leg_parameters(legs, truth_vals, bound)
    predicted = np.array([np.sqrt(np.diag(c)) for c in station_cov]) * 1000
    not_converged = sum(not c.converged for c in pipeline) + (not joint.converged) + unconverged
    report.checks += stewart_checks(config, sim, station_err, predicted, rms, float(not_converged))
    report.info = {
        "compare_rms_error_mm": {
            "one_step": leg_rms_error_mm(legs, truth_vals),
            "two_step": leg_rms_error_mm(two_step, truth_vals),
        },
        "two_step": {
            f"leg{i + 1}": dict(zip(LEG_PARAMS, map(float, np.r_[c.r, c.B, c.l])))
            for i, c in enumerate(two_step)
        },
        "station_error_um": (station_err * 1000).tolist(),
        "station_sigma_um": predicted.tolist(),
        "whitened_rms": joint.rms,
        "pipeline_rms_error_mm": leg_rms_error_mm(pipeline, truth_vals),
    }
    artifacts = dict(
        sim=sim,
        poses=data.poses,
        stations=stations,
        spheres=spheres,
        config=config,
        holdout_error_mm=err,
    )
    write_recording(out_dir, NAME, config, seed, report.info)
    return write_outputs(report, artifacts, out_dir, rrd, "calibench.scenarios.stewart")


def leg_rms_error_mm(legs: list, truth_vals: list[np.ndarray]) -> float:
    """The RMS error (mm) of the legs' 42 parameters (6 of r, B, l) against ``truth_vals``
    (6 of (7,))."""
    est = np.array([np.r_[c.r, c.B, c.l] for c in legs])
    return float(np.sqrt(np.mean((est - np.array(truth_vals)) ** 2)))


def leg_parameters(
    legs: list[LegCalibration], truth_vals: list[np.ndarray], bound: np.ndarray
) -> list[Parameter]:
    """The report's 42 leg parameters (mm): each leg's estimate and std against the truth
    ``truth_vals`` (6 of (7,)), within TOL_SIGMA of its std, with its CRLB ``bound`` (42,)."""
    out = []
    for i, c in enumerate(legs):
        est = np.r_[c.r, c.B, c.l]
        for k, name in enumerate(LEG_PARAMS):
            out.append(
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
    return out


def stewart_checks(
    config: StewartConfig,
    sim: StewartSim,
    station_err_mm: np.ndarray,
    station_sigma_um: np.ndarray,
    rms_um: dict[str, float],
    not_converged: float,
) -> list[Check]:
    """The run's checks: the loop's closure, the stations' errors (3,) mm against 5 times their
    propagated 1-sigma (3, 3) um, the held-out poses' RMS ``rms_um`` before and after each
    calibration, and the solves that ran out of iterations."""
    return [
        Check(
            "loop_closure_um",
            sim.max_closure_um,
            config.closure_limit_um,
            note="largest gap between a leg's end and its platform hinge over every pose set",
        ),
        Check(
            "station_error_um",
            float(station_err_mm.max() * 1000),
            float(5 * station_sigma_um.max() * np.sqrt(3)),
            note="largest station position error; limit 5 x its propagated 1-sigma (Eq. 4-5)",
        ),
        Check(
            "pose_rms_before_um",
            rms_um["before"],
            None,
            note=f"{config.n_holdout} held-out poses, nominal parameters",
        ),
        Check(
            "pose_rms_after_um",
            rms_um["after"],
            config.after_limit_um,
            note="held-out poses, one-step calibration",
        ),
        Check(
            "pose_rms_after_two_step_um",
            rms_um["two_step"],
            None,
            note="held-out poses, two-step calibration",
        ),
        # a solve that ran out of iterations would report its last iterate as if it were the answer
        Check(
            "solves_not_converged",
            not_converged,
            0.0,
            note="the six legs' one-step Gauss-Newton, the joint adjustment, the "
            "multilaterations, the two-step spheres and the held-out poses' forward kinematics",
        ),
    ]


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
    lengths_mm = np.array(lengths)
    return two_step_leg(
        g.reflectors_mm[:3],
        stations,
        lengths_mm,
        config.length_sigma_mm(lengths_mm),
        np.array(orientations),
        np.array(places),
        locked,
    )


def prior(config: StewartConfig, rng: np.random.Generator) -> StewartConfig:
    """The hinges' and lengths' errors are drawn by the simulator from the run's seed (hinges
    N(0, 0.4 mm), initial lengths N(0, 0.5 mm)): nothing more to draw here."""
    return config
