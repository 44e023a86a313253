"""The as-built serial arm, its physics, and its reference instruments.

Truth: the kinematic parameter errors baked into the MJCF's body frames (default for the seed's
arm: its Table 1), each joint's stiffness (a spring between the motor, whose angle the encoder
reads, and the link), the tracker's pose relative to the arm's base, the cones of a calibrated
length bar.

Physics: with finite stiffness the link settles where its spring holds gravity. MuJoCo gives
the gravity torques (``qfrc_bias`` at rest: its recursive Newton-Euler over the MJCF's masses)
and :meth:`ArmSim.link_angles` solves k (q - q_motor) = tau_gravity(q) by fixed-point iteration
on them; a test checks the result against the rest MuJoCo reaches by stepping the damped model.
MuJoCo's kinematics then give the true tool point.

Instruments:
- a laser tracker: range and two angles of the tool point, each with its own noise;
- single-point articulation: the probe seated in a cone while the arm takes many postures;
- a length bar of calibrated length between two cones.
"""

from __future__ import annotations

import threading

import mujoco
import numpy as np

from calibench.errors import BadInput
from calibench.scenes.arm_cmm import ArmDescription, load_arm
from calibench.scenes.arm_mjcf import as_built_model, write_as_built
from calibench.sim.arm_tree_twin import TreeStatics
from calibench.sim.arm_truth import (  # noqa: F401  (re-exported: the twin's truth's old home)
    TABLE1_DELTA,
    ArmTruth,
    default_errors,
    drawn_errors,
    table1_errors,
)


def _within(q: np.ndarray, lim: np.ndarray) -> np.ndarray | None:
    """The angles ``q`` (N,) rad, each turned by whole turns into [-pi, pi) or, failing that, into
    its range ``lim`` (N, 2); None if a joint's angle is in no turn of its range."""
    out = (q + np.pi) % (2 * np.pi) - np.pi
    for turn in (0.0, 2 * np.pi, -2 * np.pi):
        inside = (out + turn >= lim[:, 0]) & (out + turn <= lim[:, 1])
        out = np.where(~((out >= lim[:, 0]) & (out <= lim[:, 1])) & inside, out + turn, out)
    return out if np.all((out >= lim[:, 0]) & (out <= lim[:, 1])) else None


def gravity_at_rest(model: mujoco.MjModel, data: mujoco.MjData, out: np.ndarray) -> np.ndarray:
    """The torque gravity puts on every degree of freedom at ``data.qpos``, at rest: MuJoCo's
    inverse dynamics, written into ``out`` (nv,) N m (or N m per rad of a spring's hinge) and
    returned. Sets ``data.qvel`` to zero."""
    data.qvel[:] = 0.0
    mujoco.mj_kinematics(model, data)
    mujoco.mj_comPos(model, data)
    # the bodies' velocities at rest: rne's velocity products read cvel, which a step before
    # (settle_by_stepping) leaves at the last state's
    mujoco.mj_comVel(model, data)
    mujoco.mj_rne(model, data, 0, out)
    np.negative(out, out=out)  # qfrc_bias at rest holds gravity: gravity's own is its negative
    return out


DEFAULT_TRUTH = ArmTruth()  # the seed's errors (Table 1, or a fixed draw), rigid

# one reusable (model, data) per thread and setup, for :class:`ArmSim`'s ``reuse``
_TWINS = threading.local()


def _reused_twin(arm: ArmDescription, values: np.ndarray, tool_mm: np.ndarray, *setup) -> tuple:
    """This thread's (model, data) of ``arm`` in ``setup`` (stiffness, tracker pose, cones), the
    as-built ``values`` and ``tool_mm`` written into the model in place (:func:`write_as_built`);
    compiled once per setup, again only when a link's capsule becomes a sphere or back."""
    key = (arm,) + tuple(
        None if v is None else tuple(np.ravel(np.asarray(v, float)).tolist()) for v in setup
    )
    cache = getattr(_TWINS, "cache", None)
    if cache is None:
        cache = _TWINS.cache = {}
    twin = cache.get(key)
    if twin is not None and write_as_built(twin[0], arm, values, tool_mm):
        model, data, spring = twin
        model.qpos_spring[:] = spring  # what a previous sim's stepping moved
        mujoco.mj_setConst(model, data)
        return model, data
    model = as_built_model(arm, values, tool_mm, *setup)
    data = mujoco.MjData(model)
    if len(cache) >= 4:
        cache.clear()
    cache[key] = (model, data, model.qpos_spring.copy())
    return model, data


class ArmSim(TreeStatics):
    """The as-built arm in MuJoCo. ``arm``: a description or the name/path of one, serial or
    branched (its followers and flexing links' statics: :class:`TreeStatics`).

    ``reuse``: write this arm into the thread's last MuJoCo model of the same arm and setup
    instead of compiling one (a Monte-Carlo trial: compiling and a new MjData are a seventh of
    its time). The model is then shared: the next ``reuse`` sim of that setup overwrites it,
    so a reused sim is for one piece of work at a time, not to keep beside another."""

    def __init__(
        self, arm: ArmDescription | str, truth: ArmTruth = DEFAULT_TRUTH, reuse: bool = False
    ):
        self.arm = load_arm(arm) if isinstance(arm, str) else arm
        self.truth = truth
        N, T = self.arm.n_joints, self.arm.n_tools
        delta = np.asarray(truth.delta if truth.delta else default_errors(self.arm), float)
        if len(delta) != 5 * N + 3 * T:
            raise BadInput(
                f"truth.delta has {len(delta)} values; the arm {self.arm.name} needs 5 x {N} + "
                f"3{f' x {T}' if T > 1 else ''}"
            )
        self.delta = delta
        k = (
            np.asarray(truth.stiffness_nm_per_rad, float)
            if len(truth.stiffness_nm_per_rad)
            else np.full(N, np.inf)
        )
        if len(k) != N or np.any(k <= 0):
            raise BadInput(
                f"truth.stiffness_nm_per_rad: {N} positive values (inf for a rigid joint)"
            )
        if any(np.isfinite(k[f - 1]) for f in self.arm.followers()):
            raise BadInput(
                "truth.stiffness_nm_per_rad: a joint that follows others has no spring of its own "
                "(inf): the joints it follows carry its load"
            )
        self.stiffness = k
        kf = np.asarray(truth.flex_stiffness_nm_per_rad, float)
        if len(kf) and (len(kf) != N or np.any(~(kf > 0))):
            raise BadInput(
                f"truth.flex_stiffness_nm_per_rad: {N} positive values (inf for a rigid link)"
            )
        self.flex = {j + 1: float(v) for j, v in enumerate(kf) if np.isfinite(v)}
        self.coupling = self.arm.motor_to_joint()
        if len(truth.cable_stiffness_nm_per_rad):
            kc = np.asarray(truth.cable_stiffness_nm_per_rad, float)
            if len(kc) != N or np.any(~(kc > 0)):
                raise BadInput(
                    f"truth.cable_stiffness_nm_per_rad: {N} positive values (inf for a rigid cable)"
                )
            cable_c = 1.0 / kc
        else:
            cable_c = self.arm.cable_compliance()
        # joint deflection = this @ the joints' gravity torques: each joint's own spring, and each
        # motor's cable stretched by the torque the coupling carries back to it (virtual work:
        # motor torques = coupling.T @ joint torques), its stretch passed on to the joints
        self.compliance = (
            np.diag(np.where(np.isfinite(k), 1.0 / k, 0.0))
            + (self.coupling * cable_c) @ self.coupling.T
        )
        self.cable_compliance = cable_c
        f = np.asarray(truth.cable_friction_nm, float) if len(truth.cable_friction_nm) else None
        if f is not None and (len(f) != N or np.any(~(f >= 0)) or np.any(~np.isfinite(f))):
            raise BadInput(f"truth.cable_friction_nm: {N} values, each finite and at least 0")
        self.cable_friction = f
        R, p = truth.tracker2base()
        q = np.empty(4)
        mujoco.mju_mat2Quat(q, R.ravel())
        args = (
            self.arm,
            self.arm.nominal() + delta[: 5 * N].reshape(N, 5),
            self.arm.tool_offsets() + delta[5 * N :].reshape(T, 3),
            k,
            p / 1000,
            q,
            (np.asarray(truth.cone_a_mm) / 1000, np.asarray(truth.cone_b_mm) / 1000),
        )
        if reuse and not self.flex:  # a flexing link's hinges follow its as-built frame: compiled
            self.model, self.data = _reused_twin(*args)
        else:
            self.model = as_built_model(*args, flex=self.flex or None)
            self.data = mujoco.MjData(self.model)
        self._probe = self.model.site("probe").id
        self._jac = np.zeros((3, self.model.nv))
        self._tree_setup()
        # the cables' springs, for MuJoCo's own statics (a test's check; a follower's tendon has
        # none)
        if self.model.ntendon and not self.arm.followers():
            self.model.tendon_stiffness[:] = np.where(
                cable_c > 0, 1.0 / np.maximum(cable_c, 1e-300), 0.0
            )

    @property
    def n_joints(self) -> int:
        """The arm's number of joints."""
        return self.arm.n_joints

    @property
    def compliant(self) -> bool:
        """Whether any joint, cable or link gives way (the postures then sag under gravity)."""
        return bool(np.any(self.compliance != 0)) or bool(self.flex)

    # --- physics ----------------------------------------------------------------------------------
    def gravity_torques(self, q_rad: np.ndarray) -> np.ndarray:
        """The torque gravity puts on each joint at rest at joint angles (n, N) (rigid links; a
        follower's angle made from its joints'), MuJoCo's inverse dynamics, (n, N) N m."""
        q = np.atleast_2d(q_rad)
        if not self.plain:
            return np.stack([self._gravity_at(p)[self._hinge_dof] for p in self.qpos_of(q)])
        out = np.empty(q.shape)
        model, data, rne = self.model, self.data, self._rne
        qpos = data.qpos
        for i in range(len(q)):
            qpos[:] = q[i]
            out[i] = gravity_at_rest(model, data, rne)
        return out

    @property
    def _rne(self) -> np.ndarray:
        if not hasattr(self, "_rne_buf"):
            self._rne_buf = np.zeros(self.model.nv)
        return self._rne_buf

    def link_angles(
        self, q_motor: np.ndarray, tol_rad: float = 1e-13, max_iter: int = 50
    ) -> np.ndarray:
        """Where the links settle for motor angles (n, N) (in joint units: coupling @ the motors'
        angles): q - q_motor = compliance @ tau_gravity(q), the joints' springs and the cables'.

        Fixed-point iteration on MuJoCo's gravity torques; rigid joints stay at the motor angle.
        """
        q_motor = np.atleast_2d(np.asarray(q_motor, float))
        if not self.plain:
            return self.settled(q_motor, tol_rad, max_iter)[:, self._hinge]
        if not self.compliant:
            return q_motor.copy()
        f = self.cable_friction
        if f is not None and np.any(f * self.cable_compliance):
            return self._link_angles_with_friction(q_motor, f, tol_rad, max_iter)
        diagonal = not np.any(self.compliance - np.diag(np.diag(self.compliance)))
        c = np.diag(self.compliance) if diagonal else None
        q = q_motor.copy()
        for _ in range(max_iter):
            tau = self.gravity_torques(q)
            q_new = q_motor + (c * tau if c is not None else tau @ self.compliance.T)
            if np.max(np.abs(q_new - q)) < tol_rad:
                return q_new
            q = q_new
        raise RuntimeError(
            "the arm's static equilibrium did not converge (stiffness too low for its weight?)"
        )

    def _link_angles_with_friction(
        self, q_motor: np.ndarray, friction_nm: np.ndarray, tol_rad: float, max_iter: int
    ) -> np.ndarray:
        """:meth:`link_angles` for cables whose drive holds a dry friction f, the postures (n, N)
        reached in their order, slowly: each motor's cable stretch s stays where the last posture
        left it (the link held while the motor turns, s falls by the motor's move) until the
        torque it carries, t = coupling.T @ tau_gravity, pushes it out of the band
        |s - c t| <= c f (Coulomb friction on a spring: a play operator). The first posture
        starts at the band's centre. A move longer than the band leaves the link lagging its
        motor by c f in the direction it turned; a shorter one, by less."""
        C, c = self.coupling, self.cable_compliance
        band = c * friction_nm
        joint_c = np.diag(self.compliance - (C * c) @ C.T)  # each joint's own spring
        m = np.linalg.solve(C, q_motor.T).T
        out = np.empty_like(q_motor)
        stretch = None
        for i, qm in enumerate(q_motor):
            q = qm.copy()
            for _ in range(max_iter):
                tau = self.gravity_torques(q)[0]
                centre = c * (C.T @ tau)
                held = centre if stretch is None else stretch - (m[i] - m[i - 1])
                s = np.clip(held, centre - band, centre + band)
                q_new = qm + C @ s + joint_c * tau
                if np.max(np.abs(q_new - q)) < tol_rad:
                    break
                q = q_new
            else:
                raise RuntimeError(
                    "the arm's static equilibrium did not converge (stiffness too low for its "
                    "weight?)"
                )
            out[i], stretch = q_new, s
        return out

    def cable_references(self, q_motor: np.ndarray) -> None:
        """Set the MuJoCo cables' rest lengths to motor angles ``q_motor`` (N,) (joint units):
        each cable's length is its motor's angle seen from the joints (inverse coupling)."""
        m = np.linalg.solve(self.coupling, np.asarray(q_motor, float))
        self.model.tendon_lengthspring[:] = m[:, None]

    def settle_by_stepping(self, q_motor: np.ndarray, seconds: float = 10.0) -> np.ndarray:
        """The same equilibrium reached the long way: the model stepped to rest from the motor
        angle, its springs referenced to it and each joint critically damped (for the test that
        checks :meth:`link_angles`). Every joint needs a finite stiffness here (a follower none:
        its equality holds it). Returns the qpos (the joints' angles on a serial arm)."""
        if not self.plain:
            return self.step_tree_to_rest(q_motor, seconds)
        if not np.all(np.isfinite(self.stiffness)):
            raise ValueError("stepping to rest needs a spring on every joint")
        q_motor = np.asarray(q_motor, float)
        self.model.qpos_spring[:] = q_motor
        self.data.qpos[:], self.data.qvel[:] = q_motor, 0.0
        mujoco.mj_forward(self.model, self.data)
        M = np.zeros((self.model.nv, self.model.nv))
        mujoco.mj_fullM(self.model, self.data, M)
        saved = self.model.dof_damping.copy()
        self.model.dof_damping[:] = 2 * np.sqrt(self.stiffness * np.diag(M))
        try:
            for _ in range(int(seconds / self.model.opt.timestep)):
                mujoco.mj_step(self.model, self.data)
        finally:
            self.model.dof_damping[:] = saved
        return self.data.qpos.copy()

    # --- truth ----------------------------------------------------------------------------------
    def set_posture(self, q_rad: np.ndarray) -> None:
        """Put the twin at joint angles ``q_rad`` (N,) and update its kinematics."""
        self.data.qpos[:] = q_rad
        mujoco.mj_kinematics(self.model, self.data)

    def point_mm(self, q_link: np.ndarray, tool: np.ndarray | None = None) -> np.ndarray:
        """True tool points (base frame) for link angles (n, N) -> (n, 3) mm: each row's
        ``tool`` (n,) (0-based; the first if None), the links rigid."""
        q = np.atleast_2d(q_link)
        if not self.plain or self.arm.n_tools > 1:
            return self.points_at(self.qpos_of(q), tool)
        out = np.empty((len(q), 3))
        # the loop is the time of a Monte-Carlo trial's truth: no lookups in it (views stay valid,
        # MuJoCo writes into the same buffers)
        model, data, kinematics = self.model, self.data, mujoco.mj_kinematics
        qpos, probe = data.qpos, data.site_xpos[self._probe]
        for i in range(len(q)):
            qpos[:] = q[i]
            kinematics(model, data)
            out[i] = probe
        return out * 1000

    def probe_mm(self, q_motor: np.ndarray, tool: np.ndarray | None = None) -> np.ndarray:
        """True tool points for motor angles (n, N): the links settled under gravity first, each
        row's ``tool`` (n,) (0-based; the first if None)."""
        if not self.plain:
            return self.points_at(self.settled(q_motor), tool)
        return self.point_mm(self.link_angles(q_motor), tool)

    # --- postures and instruments -----------------------------------------------------------------
    def random_postures(
        self, n: int, rng: np.random.Generator, min_z_mm: float | None = None
    ) -> np.ndarray:
        """Motor angles within the description's ranges whose tool points stay above
        ``min_z_mm`` (default: 0.3 of the reach below the base), (n, N); a follower's column its
        angle from the joints it follows."""
        lim = np.array(self.arm.range_rad)
        floor = -0.3 * self.arm.reach_mm if min_z_mm is None else min_z_mm
        out, found = [], 0
        for _ in range(1000):
            q = self.arm.joint_angles(rng.uniform(lim[:, 0], lim[:, 1], (n, self.n_joints)))
            low = np.min(
                [self.point_mm(q, np.full(n, t))[:, 2] for t in range(self.arm.n_tools)], axis=0
            )
            out.append(q[low > floor])
            found += len(out[-1])
            if found >= n:
                return np.concatenate(out)[:n]
        raise BadInput(f"the arm {self.arm.name} rarely keeps its tool above z = {floor:.0f} mm")

    def postures_in_cone(self, cone_mm: np.ndarray, n: int, rng: np.random.Generator) -> np.ndarray:
        """n different motor postures with the probe seated in the cone at ``cone_mm``: each
        seating puts the ball's centre ``cone_seat_um`` (1-sigma) off the cone's centre (inverse
        kinematics on MuJoCo's site Jacobian, damped least squares, from random starts; the
        links' sag under gravity is taken into account)."""
        cone = np.asarray(cone_mm, float) / 1000
        lim = np.array(self.arm.range_rad)
        out: list[np.ndarray] = []
        tries = 0
        while len(out) < n:
            tries += 1
            if tries > 50 * n:
                raise BadInput(
                    f"the cone at ({', '.join(f'{v:g}' for v in np.asarray(cone_mm, float))}) mm "
                    f"is out of the arm {self.arm.name}'s reach"
                )
            q = rng.uniform(lim[:, 0], lim[:, 1])
            target = cone + rng.normal(0, self.truth.cone_seat_um * 1e-6, 3)
            for _ in range(100):
                sag = self.link_angles(q)[0] - q
                self.set_posture(q + sag)
                mujoco.mj_comPos(self.model, self.data)  # the Jacobian needs the dof axes
                err = target - self.data.site_xpos[self._probe]
                if np.linalg.norm(err) < 1e-12:
                    break
                mujoco.mj_jacSite(self.model, self.data, self._jac, None, self._probe)
                J = self._jac
                q = q + J.T @ np.linalg.solve(J @ J.T + 1e-6 * np.eye(3), err)
            if np.linalg.norm(err) < 1e-10:
                seated = _within(q, lim)
                if seated is not None:  # a seating the joints' ranges forbid is no seating
                    out.append(seated)
        return np.array(out)

    def encoders(self, q_motor: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """What the joint encoders read, (n, N) rad."""
        return q_motor + rng.normal(0, self.truth.encoder_noise_urad * 1e-6, np.shape(q_motor))

    def tracker(self, q_motor: np.ndarray, rng: np.random.Generator | None) -> np.ndarray:
        """Range (mm), azimuth and elevation (rad) of the tool point, (n, 3); exact without rng."""
        R, p = self.truth.tracker2base()
        y = (self.probe_mm(q_motor) - p) @ R  # into the tracker frame
        rng_mm = np.linalg.norm(y, axis=1)
        a, b = self.truth.range_noise_um
        sph = np.stack([rng_mm, np.arctan2(y[:, 1], y[:, 0]), np.arcsin(y[:, 2] / rng_mm)], axis=1)
        if rng is None:
            return sph
        noise = np.stack(
            [
                rng.normal(0, (a + b * rng_mm / 1000) / 1000),
                rng.normal(0, self.truth.angle_noise_urad * 1e-6, len(y)),
                rng.normal(0, self.truth.angle_noise_urad * 1e-6, len(y)),
            ],
            axis=1,
        )
        return sph + noise

    def tracker_sigma(self, measured: np.ndarray) -> np.ndarray:
        """The tracker's stated 1-sigma of each measurement (range, az, el), (n, 3)."""
        a, b = self.truth.range_noise_um
        ang = np.full(len(measured), self.truth.angle_noise_urad * 1e-6)
        return np.stack([(a + b * measured[:, 0] / 1000) / 1000, ang, ang], axis=1)

    def base2tracker(self) -> tuple[np.ndarray, np.ndarray]:
        """The base-to-tracker transform, (R (3, 3), t (3,) mm)."""
        R, p = self.truth.tracker2base()
        return R.T, -R.T @ p
