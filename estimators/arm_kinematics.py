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
        per = e[:24].reshape(6, 4)
        a = self.a_mm + np.r_[per[:, 0], 0.0]
        d = self.d_mm + np.r_[per[:, 1], e[24]]
        alpha = self.alpha_rad + np.r_[per[:, 2], 0.0]
        theta0 = np.r_[per[:, 3], 0.0]
        return a, d, alpha, theta0


def table1_delta(path) -> np.ndarray:
    """The 25 parameter errors of the seed's Table 1, in PARAM_NAMES order (mm, rad)."""
    t = np.genfromtxt(path, delimiter=",", names=True)
    per = np.stack([t["delta_a_mm"], t["delta_d_mm"], t["delta_alpha_rad"], t["delta_theta_rad"]], axis=1)
    return np.r_[per[:6].ravel(), t["delta_d_mm"][6]]


def _dh(theta, d, a, alpha) -> np.ndarray:
    """DH transforms, theta (n,) and scalars -> (n, 4, 4)."""
    ct, st = np.cos(theta), np.sin(theta)
    ca, sa = np.cos(alpha), np.sin(alpha)
    T = np.zeros(theta.shape + (4, 4))
    T[..., 0, 0], T[..., 0, 1], T[..., 0, 2], T[..., 0, 3] = ct, -st * ca, st * sa, a * ct
    T[..., 1, 0], T[..., 1, 1], T[..., 1, 2], T[..., 1, 3] = st, ct * ca, -ct * sa, a * st
    T[..., 2, 1], T[..., 2, 2], T[..., 2, 3] = sa, ca, d
    T[..., 3, 3] = 1.0
    return T


def frames(chain: DHChain, q_rad: np.ndarray, delta: np.ndarray | None = None) -> np.ndarray:
    """Frames 0..7 in the base frame, (n, 8, 4, 4), for postures (n, 6)."""
    q = np.atleast_2d(np.asarray(q_rad, float))
    a, d, alpha, th0 = chain.actual(np.zeros(25) if delta is None else delta)
    n = len(q)
    F = np.empty((n, 8, 4, 4))
    F[:, 0] = np.eye(4)
    for i in range(7):
        theta = (q[:, i] if i < N_JOINTS else np.zeros(n)) + th0[i]
        F[:, i + 1] = F[:, i] @ _dh(theta, d[i], a[i], alpha[i])
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
             offset_mm: np.ndarray | None = None) -> np.ndarray:
    """d(point) / d(delta), (n, 3, 25), analytic.

    For link i (joint frame z_{i-1}, origin o_{i-1}; after Rot(Z) and the translations, x_i and
    o_i): d/d theta_i = z_{i-1} x (p - o_{i-1}), d/d d_i = z_{i-1}, d/d a_i = x_i,
    d/d alpha_i = x_i x (p - o_i).
    """
    F = frames(chain, q_rad, delta)
    p = F[:, 7, :3, 3]
    if offset_mm is not None:
        p = p + F[:, 7, :3, :3] @ np.asarray(offset_mm, float)
    n = len(F)
    J = np.empty((n, 3, 25))
    for i in range(6):
        z_prev, o_prev = F[:, i, :3, 2], F[:, i, :3, 3]
        x_i, o_i = F[:, i + 1, :3, 0], F[:, i + 1, :3, 3]
        J[:, :, 4 * i + 0] = x_i
        J[:, :, 4 * i + 1] = z_prev
        J[:, :, 4 * i + 2] = np.cross(x_i, p - o_i)
        J[:, :, 4 * i + 3] = np.cross(z_prev, p - o_prev)
    J[:, :, 24] = F[:, 6, :3, 2]  # dd7 moves along z_6
    return J
