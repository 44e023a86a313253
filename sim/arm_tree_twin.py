"""The statics of a branched arm's twin (:class:`~calibench.sim.arm_cmm.ArmSim` on a tree): its
followers and its links' lateral flex, on top of the joints' springs.

- A follower (a joint without an encoder of its own, its angle a q_i + b q_j) has its MuJoCo
  hinge held to the joints it follows by an equality on a fixed tendon (the MJCF's, what stepping
  holds); the statics set its angle from theirs exactly, and carry its gravity torque back to
  them by virtual work (tau_i += a tau_f): a joint's spring holds what its followers carry.
- A link that flexes is two segments joined halfway by two hinges across it, each with its
  spring (``ArmTruth.flex_stiffness_nm_per_rad``); the statics hold MuJoCo's gravity torque on
  each hinge by its spring (angle = tau / k, reference zero).

:meth:`TreeStatics.settled` solves both with the joints' springs by fixed-point iteration on
MuJoCo's inverse dynamics (``mj_rne``); a test checks it against the rest MuJoCo steps to.
"""

from __future__ import annotations

import mujoco
import numpy as np

from calibench.scenes.arm_cmm import ArmDescription


class TreeStatics:
    """A mixin of :class:`~calibench.sim.arm_cmm.ArmSim`: the twin's qpos beyond its N joint
    angles. Needs ``arm``, ``model``, ``data``, ``stiffness`` (N,), ``compliance`` (N, N) (in the
    readings' space), ``flex`` {link: stiffness} and ``_rne``."""

    arm: ArmDescription
    model: mujoco.MjModel
    data: mujoco.MjData
    stiffness: np.ndarray
    compliance: np.ndarray
    flex: dict[int, float]

    def _tree_setup(self) -> None:
        """The joints' and flex hinges' addresses in qpos and qvel, the tools' sites, and whether
        the twin's qpos is its N joint angles in order (a serial arm: the short paths)."""
        N, model = self.arm.n_joints, self.model
        self._hinge = np.array([model.joint(f"q{i + 1}").qposadr[0] for i in range(N)])
        self._hinge_dof = np.array([model.joint(f"q{i + 1}").dofadr[0] for i in range(N)])
        bends = [f"bend{j}{s}" for j in sorted(self.flex) for s in "ab"]
        self._flex_at = np.array([model.joint(b).qposadr[0] for b in bends], int)
        self._flex_dof = np.array([model.joint(b).dofadr[0] for b in bends], int)
        self._flex_k = np.array([self.flex[j] for j in sorted(self.flex) for _ in "ab"])
        self._sites = np.array(
            [model.site("probe" if t == 0 else f"probe{t + 1}").id for t in range(self.arm.n_tools)]
        )
        self.plain = (
            model.nq == N and np.array_equal(self._hinge, np.arange(N)) and not self.arm.follows
        )

    def qpos_of(self, q_joint: np.ndarray, bend: np.ndarray | None = None) -> np.ndarray:
        """The twin's qpos (n, nq) at readings (n, N) (each follower's angle made from the joints
        it follows) and flex hinges' angles (n, 2 L) (zero if None: rigid links)."""
        q = np.atleast_2d(np.asarray(q_joint, float))
        out = np.zeros((len(q), self.model.nq))
        out[:, self._hinge] = self.arm.joint_angles(q)
        if bend is not None:
            out[:, self._flex_at] = bend
        return out

    def _gravity_at(self, qpos: np.ndarray) -> np.ndarray:
        """MuJoCo's gravity force on every dof at rest at ``qpos`` (nq,), (nv,)."""
        from calibench.sim.arm_cmm import gravity_at_rest

        self.data.qpos[:] = qpos
        return gravity_at_rest(self.model, self.data, self._rne)  # type: ignore[attr-defined]

    def _in_readings(self, tau_joint: np.ndarray) -> np.ndarray:
        """Joint torques (N,) carried onto the readings: a follower's onto the joints it follows
        (virtual work: follows.T @ tau)."""
        if self.arm.follows is None:
            return tau_joint
        return np.asarray(self.arm.follows, float).T @ tau_joint

    def settled(
        self, q_motor: np.ndarray, tol_rad: float = 1e-13, max_iter: int = 60
    ) -> np.ndarray:
        """The twin's qpos at rest (n, nq) for motor angles (n, N): each joint's link where its
        spring holds the gravity torque it carries (its followers' included), each follower at the
        angle its joints give it, each flex hinge where its spring holds MuJoCo's torque on it.
        Fixed-point iteration on MuJoCo's inverse dynamics."""
        q_motor = np.atleast_2d(np.asarray(q_motor, float))
        out = np.empty((len(q_motor), self.model.nq))
        for n, qm in enumerate(q_motor):
            q, bend = qm.copy(), np.zeros(len(self._flex_k))
            for _ in range(max_iter):
                tau = self._gravity_at(self.qpos_of(q, bend)[0])
                q_new = qm + self.compliance @ self._in_readings(tau[self._hinge_dof])
                bend_new = tau[self._flex_dof] / self._flex_k
                step = max(np.abs(q_new - q).max(), np.abs(bend_new - bend).max(initial=0.0))
                q, bend = q_new, bend_new
                if step < tol_rad:
                    break
            else:
                raise RuntimeError(
                    "the arm's static equilibrium did not converge (stiffness too low for its "
                    "weight?)"
                )
            out[n] = self.qpos_of(q, bend)[0]
        return out

    def points_at(self, qpos: np.ndarray, tool: np.ndarray | None = None) -> np.ndarray:
        """True tool points (n, 3) mm, base frame, at the twin's qpos (n, nq): each row's
        ``tool`` (n,) (0-based; the first if None)."""
        qpos = np.atleast_2d(qpos)
        sites = self._sites[np.zeros(len(qpos), int) if tool is None else np.asarray(tool, int)]
        out = np.empty((len(qpos), 3))
        for i in range(len(qpos)):
            self.data.qpos[:] = qpos[i]
            mujoco.mj_kinematics(self.model, self.data)
            out[i] = self.data.site_xpos[sites[i]]
        return out * 1000

    def step_tree_to_rest(self, q_motor: np.ndarray, seconds: float) -> np.ndarray:
        """The twin's qpos (nq,) at rest reached by stepping MuJoCo from the motor angles (N,):
        the joints' springs referenced to them, the flex springs to zero, the followers held by
        their equality constraints (soft: a follower then sits off its joints' angle by the
        constraint's violation, nanoradians), each dof near critically damped."""
        model, data = self.model, self.data
        followers = [f - 1 for f in self.arm.followers()]
        if not np.all(np.isfinite(np.delete(self.stiffness, followers))):
            raise ValueError("stepping to rest needs a spring on every joint but the followers")
        start = self.qpos_of(q_motor)[0]
        model.qpos_spring[:] = start
        data.qpos[:], data.qvel[:] = start, 0.0
        mujoco.mj_forward(model, data)
        M = np.zeros((model.nv, model.nv))
        mujoco.mj_fullM(model, data, M)
        k = np.zeros(model.nv)
        k[self._hinge_dof] = np.where(np.isfinite(self.stiffness), self.stiffness, 0.0)
        k[self._flex_dof] = self._flex_k
        # a follower has no spring: damped as stiffly as the joints it follows
        k[k == 0] = np.max(k)
        saved = model.dof_damping.copy()
        model.dof_damping[:] = 2 * np.sqrt(k * np.diag(M))
        try:
            for _ in range(int(seconds / model.opt.timestep)):
                mujoco.mj_step(model, data)
        finally:
            model.dof_damping[:] = saved
        return data.qpos.copy()
