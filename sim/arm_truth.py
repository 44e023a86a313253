"""The as-built arm's truth: the kinematic errors baked into its twin (default for the seed's
arm: its Table 1; for any other arm a fixed draw of the seed's sizes), its joints' and links'
stiffness, its cables, and its reference instruments' poses and noise (:class:`ArmTruth`). The
twin itself is :class:`calibench.sim.arm_cmm.ArmSim`."""

from __future__ import annotations

import dataclasses
import functools

import numpy as np

from calibench.scenes.arm_cmm import DEFAULT_ARM, ArmDescription

# The seed's Table 1 errors: (da, dd, dalpha, dtheta) of links 1-6 (mm, mm, rad, rad), then dd7,
# the stylus length (mm): the tool point's z in the flange frame.
TABLE1_DELTA = (
    0.10,
    -0.05,
    0.0010,
    0.0014,
    -0.08,
    0.11,
    0.0014,
    -0.0023,
    -0.12,
    0.06,
    -0.0012,
    0.0017,
    0.03,
    0.13,
    0.0017,
    0.0010,
    0.07,
    -0.04,
    0.0010,
    -0.0014,
    -0.14,
    0.05,
    -0.0010,
    0.0010,
    -0.03,
)


@functools.lru_cache(maxsize=1)
def table1_errors() -> tuple:
    """Table 1 in the general layout: (da, dd, dalpha, dtheta, dbeta) per joint, tool (x, y, z)."""
    t = np.asarray(TABLE1_DELTA)
    per = np.c_[t[:24].reshape(6, 4), np.zeros(6)]
    return tuple(np.r_[per.ravel(), 0.0, 0.0, t[24]])


def default_errors(arm: ArmDescription, seed: int = 0) -> tuple:
    """The as-built errors a run injects when the config gives none: Table 1 for the seed's arm;
    for any other arm a fixed draw of the seed's sizes (lengths 0.1 mm, angles 1 mrad; beta only
    where two axes are parallel, where it is the error DH cannot express)."""
    if arm.name == DEFAULT_ARM and arm.n_joints == 6:
        return table1_errors()
    return drawn_errors(arm, seed)


def drawn_errors(arm: ArmDescription, seed: int) -> tuple:
    """As-built errors (5 N + 3 T,) of the seed's sizes drawn for ``arm`` with ``seed``: lengths
    0.1 mm, angles 1 mrad, beta only where two axes are parallel (another arm of one drawing is
    another seed); the T tools' offsets as drawn."""
    rng = np.random.default_rng(seed)
    N = arm.n_joints
    per = np.c_[rng.normal(0, 0.1, (N, 2)), rng.normal(0, 1e-3, (N, 3))]
    per[:, 4] = 0.0
    for i, _ in arm.parallel_pairs():
        per[i - 1, 4] = rng.normal(0, 1e-3)
    return tuple(np.r_[per.ravel(), np.zeros(3 * arm.n_tools)])


@dataclasses.dataclass(frozen=True)
class ArmTruth:
    """The as-built arm and its instruments.

    delta : (5 N + 3 T,) errors, or () for :func:`default_errors`.
    stiffness_nm_per_rad : (N,) per joint, or () for a rigid arm (inf is rigid too; a joint
        that follows others has no spring of its own: inf).
    flex_stiffness_nm_per_rad : (N,) per link, or () for rigid links (inf: rigid): a link with a
        finite one is two segments joined halfway by two hinges across it, each with that spring
        (its lateral flex under the weight it carries).
    cable_stiffness_nm_per_rad : (N,) per motor of an arm with a transmission, or () for the
        description's cables (inf: a rigid cable).
    cable_friction_nm : (N,) per motor, the dry friction its cable drive holds (N m at the
        motor), or (): none. A soft cable then stays stretched where the last posture left it
        until the torque it carries leaves the friction's band (:meth:`ArmSim.link_angles`).
    """

    delta: tuple = ()
    stiffness_nm_per_rad: tuple = ()
    flex_stiffness_nm_per_rad: tuple = ()
    cable_stiffness_nm_per_rad: tuple = ()
    cable_friction_nm: tuple = ()
    tracker_pos_mm: tuple = (2200.0, -900.0, 350.0)  # the tracker's head in the base frame
    tracker_yaw_rad: float = 2.75  # it faces the arm
    tracker_tilt_rad: tuple = (0.004, -0.003)
    cone_a_mm: tuple = (450.0, 250.0, -150.0)
    cone_b_mm: tuple = (450.0, -350.0, -150.0)  # 600 mm bar
    encoder_noise_urad: float = 5.0
    range_noise_um: tuple = (5.0, 1.0)  # a + b * range(m), 1-sigma
    angle_noise_urad: float = 4.0
    cone_seat_um: float = 2.0

    def __post_init__(self):
        if (
            self.bar_length_mm < 1.0
        ):  # the bar's MJCF capsule, and its length's information, need one
            raise ValueError(
                "cone_a_mm and cone_b_mm coincide (within 1 mm): the length bar between the cones "
                "has no length"
            )

    @property
    def bar_length_mm(self) -> float:
        """The length bar's true length (mm): the distance between the two cones' centres."""
        return float(np.linalg.norm(np.subtract(self.cone_a_mm, self.cone_b_mm)))

    def tracker2base(self) -> tuple[np.ndarray, np.ndarray]:
        """The tracker frame in the base frame: R (3, 3), position (3,) mm."""
        cz, sz = np.cos(self.tracker_yaw_rad), np.sin(self.tracker_yaw_rad)
        Rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
        ax, ay = self.tracker_tilt_rad
        Rx = np.array([[1, 0, 0], [0, np.cos(ax), -np.sin(ax)], [0, np.sin(ax), np.cos(ax)]])
        Ry = np.array([[np.cos(ay), 0, np.sin(ay)], [0, 1, 0], [-np.sin(ay), 0, np.cos(ay)]])
        return Rz @ Ry @ Rx, np.asarray(self.tracker_pos_mm, float)
