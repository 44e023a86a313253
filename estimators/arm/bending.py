"""How an arm's bearings and links bend under gravity move its measured points: each a small turn
c M_perp about a point, M_perp the moment across it of the weight it carries.

- a bearing's tilt (``tilt_compliance<j>``): everything joint j carries turns about the joint's
  origin by c M_perp, M_perp the moment across its axis;
- a link's lateral flex (``flex_compliance<j>``): everything beyond link j's middle turns about
  the middle by c M_perp, M_perp the moment there of the weight beyond it, across the link.

The two are one effect only where a link bends at its joint, across the joint's axis: the turn's
centre, the weight it carries (a link's own, inboard of its middle, bends it not) and the
moment's direction all differ otherwise (docs/arm-cmm.md, "Branched arms").

On a branched arm a joint or a link moves the points of the tools it carries only: the other
arm's rows get zero columns.
"""

from __future__ import annotations

import numpy as np

from calibench.estimators.arm.kinematics import Chain, Pose, cross, joint_axes, link_middles


def carried(chain: Chain, P: Pose, joints: np.ndarray, moves: np.ndarray) -> np.ndarray:
    """``moves`` (n, k, 3) of the points of joints ``joints`` (1-based), zero on the rows whose
    tool (``P.tool``) the joint does not carry."""
    if chain.on_path.all():  # a serial arm: every joint carries the one tool
        return moves
    tool = np.zeros(len(moves), int) if P.tool is None else P.tool
    on = chain.on_path[tool][:, np.asarray(joints, int) - 1]  # (n, k)
    return moves * on[:, :, None]


def tilt_columns(chain: Chain, P: Pose, joints: np.ndarray, m_perp: np.ndarray) -> np.ndarray:
    """d(point) / d(c) of bearings ``joints`` (1-based) tilting by c M_perp (``m_perp``
    (n, k, 3) N m) about their joints' origins, (n, 3, k) mm per rad / N m."""
    _, o = joint_axes(P)
    moves = cross(m_perp, P.point[:, None] - o[:, np.asarray(joints, int) - 1])
    return carried(chain, P, joints, moves).transpose(0, 2, 1)


def flex_columns(chain: Chain, P: Pose, links: np.ndarray, m_flex: np.ndarray) -> np.ndarray:
    """d(point) / d(c) of links ``links`` (1-based joints) bending by c M_perp (``m_flex``
    (n, k, 3) N m, :func:`~calibench.estimators.arm.kinematics.flex_moments`) about their
    middles, (n, 3, k) mm per rad / N m."""
    h, _ = link_middles(P, links)
    return carried(chain, P, links, cross(m_flex, P.point[:, None] - h)).transpose(0, 2, 1)
