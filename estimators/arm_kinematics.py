"""Kinematics of a Denavit-Hartenberg arm and its full-differential error model (the arm-CMM seed).

Convention (the seed paper's): T(i-1, i) = Rot(Z, theta_i) Trans(0, 0, d_i) Trans(a_i, 0, 0)
Rot(X, alpha_i); the probe is the origin of frame 7 (link 7, the stylus, has theta_7 = 0).
Lengths in mm, angles in rad. The 25 error parameters are, for links 1-6, (da, dd, dalpha,
dtheta) each, then dd7 (the stylus length): an actual arm adds them to a, d, alpha and the
joint zero. dP = J d(delta) with the analytic 3 x 25 Jacobian of any point fixed in link 7.

Everything is vectorised over postures: q is (n, 6).
"""

from __future__ import annotations

import dataclasses

import numpy as np

N_JOINTS = 6
PARAM_NAMES = tuple(f"{k}{i}" for i in range(1, 7) for k in ("da", "dd", "dalpha", "dtheta")) + ("dd7",)
PARAM_UNITS = tuple("urad" if n.startswith(("dalpha", "dtheta")) else "mm" for n in PARAM_NAMES)


@dataclasses.dataclass(frozen=True)
class DHChain:
    """Nominal DH parameters of links 1..7, each (7,): a, d (mm), alpha (rad); theta_7 = 0."""

    a_mm: np.ndarray
    d_mm: np.ndarray
    alpha_rad: np.ndarray

    @classmethod
    def from_csv(cls, path) -> "DHChain":
        """The seed's Table 1 layout: link, a_mm, delta_a_mm, d_mm, delta_d_mm, alpha_rad, ..."""
        t = np.genfromtxt(path, delimiter=",", names=True)
        return cls(a_mm=np.asarray(t["a_mm"], float), d_mm=np.asarray(t["d_mm"], float),
                   alpha_rad=np.asarray(t["alpha_rad"], float))

    def actual(self, delta: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """(a, d, alpha, theta_offset), each (7,), of the arm with errors ``delta`` (25,)."""
        e = np.asarray(delta, float)
        per = np.zeros((7, 4))  # link 7 has only d
        per[:6] = e[:24].reshape(6, 4)
        per[6, 1] = e[24]
        return self.a_mm + per[:, 0], self.d_mm + per[:, 1], self.alpha_rad + per[:, 2], per[:, 3]


def table1_delta(path) -> np.ndarray:
    """The 25 parameter errors of the seed's Table 1, in PARAM_NAMES order (mm, rad)."""
    t = np.genfromtxt(path, delimiter=",", names=True)
    per = np.stack([t["delta_a_mm"], t["delta_d_mm"], t["delta_alpha_rad"], t["delta_theta_rad"]], axis=1)
    return np.r_[per[:6].ravel(), t["delta_d_mm"][6]]


def _dh(theta, d, a, alpha) -> np.ndarray:
    """DH transforms, theta (..., k) and d, a, alpha (k,) -> (..., k, 4, 4)."""
    ct, st = np.cos(theta), np.sin(theta)
    ca, sa = np.broadcast_to(np.cos(alpha), ct.shape), np.broadcast_to(np.sin(alpha), ct.shape)
    T = np.zeros(theta.shape + (4, 4))
    T[..., 0, 0], T[..., 0, 1], T[..., 0, 2], T[..., 0, 3] = ct, -st * ca, st * sa, a * ct
    T[..., 1, 0], T[..., 1, 1], T[..., 1, 2], T[..., 1, 3] = st, ct * ca, -ct * sa, a * st
    T[..., 2, 1], T[..., 2, 2], T[..., 2, 3] = sa, ca, d
    T[..., 3, 3] = 1.0
    return T


def _cross(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """u x v over the last axis (np.cross's axis juggling costs more than the arithmetic here)."""
    out = np.empty(np.broadcast_shapes(u.shape, v.shape))
    out[..., 0] = u[..., 1] * v[..., 2] - u[..., 2] * v[..., 1]
    out[..., 1] = u[..., 2] * v[..., 0] - u[..., 0] * v[..., 2]
    out[..., 2] = u[..., 0] * v[..., 1] - u[..., 1] * v[..., 0]
    return out


def frames(chain: DHChain, q_rad: np.ndarray, delta: np.ndarray | None = None) -> np.ndarray:
    """Frames 0..7 in the base frame, (n, 8, 4, 4), for postures (n, 6)."""
    q = np.atleast_2d(np.asarray(q_rad, float))
    a, d, alpha, th0 = chain.actual(np.zeros(25) if delta is None else delta)
    n = len(q)
    theta = np.zeros((n, 7))
    theta[:, :N_JOINTS] = q
    links = _dh(theta + th0, d, a, alpha)  # all seven links at once
    F = np.empty((n, 8, 4, 4))
    F[:, 0] = np.eye(4)
    for i in range(7):
        F[:, i + 1] = F[:, i] @ links[:, i]
    return F


def point_in_link7(chain: DHChain, q_rad: np.ndarray, delta: np.ndarray | None = None,
                   offset_mm: np.ndarray | None = None) -> np.ndarray:
    """Base-frame position of a point fixed in frame 7 (the probe when ``offset_mm`` is None),
    (n, 3)."""
    F = frames(chain, q_rad, delta)
    p = F[:, 7, :3, 3]
    if offset_mm is not None:
        p = p + F[:, 7, :3, :3] @ np.asarray(offset_mm, float)
    return p


def jacobian(chain: DHChain, q_rad: np.ndarray, delta: np.ndarray | None = None,
             offset_mm: np.ndarray | None = None, F: np.ndarray | None = None) -> np.ndarray:
    """d(point) / d(delta), (n, 3, 25), analytic.

    For link i (joint frame z_{i-1}, origin o_{i-1}; after Rot(Z) and the translations, x_i and
    o_i): d/d theta_i = z_{i-1} x (p - o_{i-1}), d/d d_i = z_{i-1}, d/d a_i = x_i,
    d/d alpha_i = x_i x (p - o_i). ``F``: the frames, when the caller has them already.
    """
    F = frames(chain, q_rad, delta) if F is None else F
    p = F[:, 7, :3, 3]
    if offset_mm is not None:
        p = p + F[:, 7, :3, :3] @ np.asarray(offset_mm, float)
    n = len(F)
    z_prev, o_prev = F[:, :6, :3, 2], F[:, :6, :3, 3]  # (n, 6, 3)
    x_i, o_i = F[:, 1:7, :3, 0], F[:, 1:7, :3, 3]
    per = np.stack([x_i, z_prev, _cross(x_i, p[:, None] - o_i), _cross(z_prev, p[:, None] - o_prev)], axis=3)
    J = np.empty((n, 3, 25))
    J[:, :, :24] = per.transpose(0, 2, 1, 3).reshape(n, 3, 24)  # (link, [a, d, alpha, theta])
    J[:, :, 24] = F[:, 6, :3, 2]  # dd7 moves along z_6
    return J
