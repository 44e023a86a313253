"""An arm's errors that follow its drives' motion, not their angle: lost motion in a joint's
gears, and the friction a cable drive leaves.

Joint j's link lags its encoder by half the lost motion b in the direction it last turned
(``dir_q`` (n, N) +1 / -1, :func:`calibench.estimators.discovery.motion.last_direction` over the
recording's order; 0 before its first move)::

    q_true = q_read - (b / 2) dir_j,    dp = -J_q (b / 2) dir_j

A cable drive's friction f holds motor m's joints back by f / k (k the cable's stiffness) in the
direction the motor last turned (``dir_motor`` (n, N), the motors' angles the inverse coupling's),
along the motor's coupling column ``c`` (N,)::

    q_true = q_read - c (b / 2) dir_m,    dp = -J_q c (b / 2) dir_m,    b = 2 f / k
"""

from __future__ import annotations

import dataclasses

import numpy as np

from calibench.estimators.discovery.arm import JointEffect, joint_column
from calibench.estimators.discovery.effect import Effect, coef_std


@dataclasses.dataclass(frozen=True)
class JointBacklash(JointEffect):
    """Lost motion of joint j's drive: b urad between its two directions of last motion."""

    name: str = "backlash"

    def __post_init__(self):
        object.__setattr__(self, "needs", ("Jq", "dir_q"))

    def applies(self, drivers):
        d = drivers.get("dir_q")
        if drivers.get("Jq") is None or d is None:
            return False
        mine = np.asarray(d)[:, self.joint - 1]
        return bool(np.any(mine > 0) and np.any(mine < 0))

    def columns(self, d):
        half = np.asarray(d["dir_q"], float)[:, self.joint - 1] / 2 * 1e-6  # coefficient: urad
        return -(joint_column(d, self.joint) * half[:, None]).reshape(-1, 1)

    def describe(self, coef, cov):
        b = float(coef[0])
        return (
            {"joint": self.joint, "urad": b},
            {"urad": coef_std(cov, 0)},
            f"joint {self.joint}'s link lags its encoder by {b / 2:+.0f} urad in the direction it "
            f"last turned ({b:.0f} urad between the two): lost motion in its drive",
        )

    def implausible(self, coef, cov):
        b = float(coef[0])
        if b >= 0:
            return ""
        return (
            f"joint {self.joint}'s lost motion fitted at {b:.3g} +- {coef_std(cov, 0):.2g} urad, "
            "below zero: a link that leads its encoder in the direction it turns is no play"
        )


@dataclasses.dataclass(frozen=True)
class CableFriction(Effect):
    """Motor m's cables hold its joints back by friction over stiffness, b / 2 urad at the motor
    in the direction it last turned, along its coupling ``column`` (N,): a motor that drives
    several joints (a differential) turns them together, which no joint's lost motion does."""

    name: str = "cable_friction"
    axis: str = "xyz"
    motor: int = 1
    column: tuple = ()

    def __post_init__(self):
        object.__setattr__(self, "needs", ("Jq", "dir_motor"))

    @property
    def key(self) -> str:
        """One candidate per motor."""
        return f"{self.name}:motor{self.motor}"

    def applies(self, drivers):
        d = drivers.get("dir_motor")
        if drivers.get("Jq") is None or d is None:
            return False
        mine = np.asarray(d)[:, self.motor - 1]
        return bool(np.any(mine > 0) and np.any(mine < 0))

    def columns(self, d):
        half = np.asarray(d["dir_motor"], float)[:, self.motor - 1] / 2 * 1e-6  # coef: urad
        turn = np.asarray(d["Jq"], float) @ np.asarray(self.column, float)  # (n, 3)
        return -(turn * half[:, None]).reshape(-1, 1)

    def describe(self, coef, cov):
        b = float(coef[0])
        joints = [j + 1 for j, v in enumerate(self.column) if v != 0]
        return (
            {"motor": self.motor, "urad": b, "joints": joints, "column": list(self.column)},
            {"urad": coef_std(cov, 0)},
            f"motor {self.motor}'s cables hold joints {' and '.join(map(str, joints))} back by "
            f"{b / 2:+.0f} urad at the motor in the direction it last turned ({b:.0f} urad "
            "between the two): the friction in its cable drive over the cables' stiffness",
        )

    def implausible(self, coef, cov):
        b = float(coef[0])
        if b >= 0:
            return ""
        return (
            f"motor {self.motor}'s cable friction fitted at {b:.3g} +- {coef_std(cov, 0):.2g} "
            "urad, below zero: joints that lead their motor in the direction it turns are not "
            "held back by friction"
        )
