"""An arm's compliances under gravity: a joint's, and a motor's cable through the coupling.

Joint j gives way by c times the gravity torque it carries (``tau`` (n, N), the twin's inverse
dynamics); a motor m's cable stretches by c times the torque the coupling carries back to it
(``column`` . tau) and the stretch turns every joint it drives by ``column`` times it::

    dp = J_q[:, j] c tau_j,    dp = (J_q @ column) c (column . tau)

and a branched arm's link bends across under the weight beyond its middle (``flex`` (n, 3)
per link: its columns, :func:`~calibench.estimators.arm.bending.flex_columns`)::

    dp = c (M_perp x (p - h))

A compliance below zero is outside its physical range (:meth:`implausible`).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from calibench.estimators.discovery.arm import JointEffect, joint_column
from calibench.estimators.discovery.effect import Effect, below_zero, coef_std


@dataclasses.dataclass(frozen=True)
class JointCompliance(JointEffect):
    """Joint j's link turns by c tau_j from its encoder's angle, tau_j the gravity torque on the
    joint (``tau`` (n, N) N m, from the twin's physics)."""

    name: str = "joint_compliance"

    def __post_init__(self):
        object.__setattr__(self, "needs", ("Jq", "tau"))

    def applies(self, drivers):
        tau = drivers.get("tau")
        return (
            drivers.get("Jq") is not None
            and tau is not None
            and np.ptp(np.asarray(tau)[:, self.joint - 1]) > 0
        )

    def columns(self, d):
        tau = np.asarray(d["tau"], float)[:, self.joint - 1]
        return (joint_column(d, self.joint) * (tau * 1e-6)[:, None]).reshape(
            -1, 1
        )  # coefficient: urad / N m

    def describe(self, coef, cov):
        c = float(coef[0])
        stiff = f" (a stiffness of {1e6 / c:.3g} N m / rad)" if c > 0 else ""
        return (
            {"joint": self.joint, "urad_per_nm": c},
            {"urad_per_nm": coef_std(cov, 0)},
            f"joint {self.joint} gives way under the gravity torque it carries: {c:.3g} urad per "
            f"N m{stiff}",
        )

    def implausible(self, coef, cov):
        return below_zero(f"joint {self.joint}'s compliance", coef, cov, "urad / N m")


@dataclasses.dataclass(frozen=True)
class CableCompliance(Effect):
    """Motor m's cable stretches by c times the torque the coupling carries back to the motor
    (``column`` . tau, ``column`` (N,) the motor's column of the motor-to-joint coupling), and the
    stretch turns every joint the motor drives by ``column`` times it. Where the motor drives
    several joints (a differential wrist) the joints turn together, which no joint's own
    compliance does."""

    name: str = "cable_compliance"
    axis: str = "xyz"
    motor: int = 1
    column: tuple = ()

    def __post_init__(self):
        object.__setattr__(self, "needs", ("Jq", "tau"))

    @property
    def key(self) -> str:
        """One candidate per motor."""
        return f"{self.name}:motor{self.motor}"

    def applies(self, drivers):
        tau = drivers.get("tau")
        return (
            drivers.get("Jq") is not None
            and tau is not None
            and np.ptp(np.asarray(tau) @ np.asarray(self.column)) > 0
        )

    def columns(self, d):
        c = np.asarray(self.column, float)
        tau_motor = np.asarray(d["tau"], float) @ c
        turn = np.asarray(d["Jq"], float) @ c  # (n, 3): the point's move per unit stretch
        return (turn * (tau_motor * 1e-6)[:, None]).reshape(-1, 1)  # coefficient: urad / N m

    def describe(self, coef, cov):
        c = float(coef[0])
        joints = [j + 1 for j, v in enumerate(self.column) if v != 0]
        stiff = f" (a stiffness of {1e6 / c:.3g} N m / rad)" if c > 0 else ""
        drives = " and ".join(f"{j}" for j in joints)
        return (
            {"motor": self.motor, "urad_per_nm": c, "joints": joints},
            {"urad_per_nm": coef_std(cov, 0)},
            f"motor {self.motor}'s cable stretches under the torque it carries: {c:.3g} urad per "
            f"N m{stiff}, turning joint{'s' if len(joints) > 1 else ''} {drives}"
            + (" together" if len(joints) > 1 else ""),
        )

    def implausible(self, coef, cov):
        return below_zero(f"motor {self.motor}'s cable compliance", coef, cov, "urad / N m")


@dataclasses.dataclass(frozen=True)
class LinkFlex(Effect):
    """Link j bends across itself under the weight it carries beyond its middle: everything
    beyond turns by c M_perp about the middle (``flex`` among the drivers: {link: (n, 3) mm per
    rad / N m}, a branched arm's links where its branches meet)."""

    name: str = "link_flex"
    axis: str = "xyz"
    link: int = 1

    def __post_init__(self):
        object.__setattr__(self, "needs", ("flex",))

    @property
    def key(self) -> str:
        """One candidate per link."""
        return f"{self.name}:link{self.link}"

    def applies(self, drivers):
        flex = drivers.get("flex")
        return bool(flex) and self.link in flex and np.ptp(flex[self.link]) > 0

    def columns(self, d):
        return (np.asarray(d["flex"][self.link], float) * 1e-6).reshape(-1, 1)  # urad / N m

    def describe(self, coef, cov):
        c = float(coef[0])
        stiff = f" (a stiffness of {1e6 / c:.3g} N m / rad)" if c > 0 else ""
        return (
            {"link": self.link, "urad_per_nm": c},
            {"urad_per_nm": coef_std(cov, 0)},
            f"link {self.link} bends across under the weight it carries: {c:.3g} urad per N m"
            f"{stiff}",
        )

    def implausible(self, coef, cov):
        return below_zero(f"link {self.link}'s lateral compliance", coef, cov, "urad / N m")
