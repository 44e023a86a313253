"""An arm joint's errors that follow its motion, not its angle: lost motion in its gears.

Joint j's link lags its encoder by half the lost motion b in the direction it last turned
(``dir_q`` (n, N) +1 / -1, :func:`calibench.estimators.discovery.motion.last_direction` over the
recording's order; 0 before its first move)::

    q_true = q_read - (b / 2) dir_j,    dp = -J_q (b / 2) dir_j
"""

from __future__ import annotations

import dataclasses

import numpy as np

from calibench.estimators.discovery.arm import JointEffect, joint_column
from calibench.estimators.discovery.effect import coef_std


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
