"""The arm's parameters as its identification problems share them: their typical sizes, the
columns that set an identifiable basis's tolerance, and the words for parameters dropped across
parallel axes. By name, so every problem (points, a tracker's readings, cones) agrees."""

from __future__ import annotations

import functools
import re
from collections.abc import Callable

import numpy as np


def parameter_scales(names) -> np.ndarray:
    """Typical sizes to make columns comparable: 0.1 mm for lengths, 1 mrad for angles, 100 urad
    for a joint's angle error terms,
    10 urad / N m for a joint's compliance (a robot's gearbox: 1e5 N m / rad), 1 urad / N m for a
    bearing's tilt and a link's lateral flex."""
    return np.array(_scales(tuple(names)))


@functools.lru_cache(maxsize=64)
def _scales(names: tuple) -> tuple:
    """The typical sizes of ``names``' errors, cached: a problem asks at every basis and bound."""
    return tuple(
        1e-3
        if n.startswith(("dalpha", "dtheta", "dbeta", "tracker_r", "base_r", "cone_r"))
        else 1e-4
        if n.startswith("angle_")
        else 1e-5
        if n.startswith(("compliance", "cable_compliance"))
        else 1e-6
        if n.startswith(("tilt_compliance", "flex_compliance"))
        else 0.1
        for n in names
    )


# every compliance's name starts with one of these (a joint's, a bearing's tilt, a link's lateral
# flex, a cable's)
COMPLIANCE_PREFIXES = ("compliance", "tilt_compliance", "flex_compliance", "cable_compliance")


def geometric_columns(names) -> np.ndarray:
    """(n,) bool: the parameters that are not a compliance. The largest of their columns sets an
    identifiable basis's tolerance: a compliance's column grows with the arm's torques (a 200 kg
    arm's, 25 times an angle's), and would otherwise lift the tolerance over columns of the
    geometry that the data do determine."""
    return np.array(
        [not n.startswith(COMPLIANCE_PREFIXES) for n in names],
        bool,
    )


class ArmParameters:
    """What an arm's identification problems share beyond the protocol's own data: the typical
    sizes of their parameters and the columns that set the rank tolerance, both by name."""

    @property
    def names(self) -> tuple[str, ...]:
        """Every parameter's name, in column order (each problem says its own)."""
        raise NotImplementedError

    def scales(self) -> np.ndarray:
        """(n,) typical sizes of the parameters' errors (:func:`parameter_scales`)."""
        return parameter_scales(self.names)

    def reference(self) -> np.ndarray:
        """(n,) bool: the columns that set the rank tolerance (:func:`geometric_columns`)."""
        return geometric_columns(self.names)


def parallel_axes_note(parallel: list[tuple[int, int]]) -> Callable[[str, list[str]], str]:
    """A note for :func:`~calibench.estimators.identification.basis.identifiable_basis`: ``'
    (parallel axes i-j)'`` when a dropped d or theta depends on a neighbour across one of the
    consecutive parallel joint pairs ``parallel``."""

    def note(name: str, partners: list[str]) -> str:
        m = re.fullmatch(r"(dd|dtheta|da|dalpha)(\d+)", name)
        if not m:
            return ""
        j = int(m.group(2))
        for i, k in parallel:
            if j in (i, k) or j == k + 1:
                for p in partners:
                    mp = re.fullmatch(r"(dd|dtheta|da|dalpha|dbeta)(\d+)", p)
                    if mp and int(mp.group(2)) in (i, k, k + 1) and int(mp.group(2)) != j:
                        return f" (parallel axes {i}-{k})"
        return ""

    return note
