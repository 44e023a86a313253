"""Candidate effects of a serial arm: what its twin may have left out (calibench discover
arm-cmm)."""

from __future__ import annotations

import dataclasses
from typing import TypedDict

import numpy as np

from calibench.estimators.arm.session import SESSION_PRIOR_RAD
from calibench.estimators.discovery.effect import (
    Drivers,
    Effect,
    amplitude,
    coef_std,
    drift_vector,
)
from calibench.estimators.discovery.harmonics import best_harmonic


class ArmDrivers(TypedDict, total=False):
    """What an N-joint arm's candidates see, at n postures: ``q`` (n, N) rad; the chain's
    parameter Jacobian ``J`` (n, 3, 5 N + 3) and ``Jq`` (n, 3, N) d(point) / d(q) at the
    geometry's solution; ``grow`` (5 N + 3,) the chain's lengths in the Jacobian's layout;
    ``tau`` (n, N) the joints' gravity torques (N m, the twin's inverse dynamics; None without
    masses); ``point`` (n, 3) mm and ``flange_R`` (n, 3, 3) of the chain there; ``delta_twin``
    (5 N + 3,) the twin's own chain errors; ``rec`` (n,) each posture's recording; ``t_s``,
    ``temp_c`` (n,) or None; ``dir_q`` (n, N) each joint's direction of last motion and, with a
    transmission, ``dir_motor`` (n, N) each motor's; on a branched arm ``tool`` (n,) each row's
    tool (``Jq`` and ``tau`` then on the readings: a joint's turn moves its followers too) and
    ``flex`` {link: (n, 3)} how each link its branches meet on moves the points bending across,
    per rad / N m; ``followers`` the joints without a reading of their own."""

    q: np.ndarray
    J: np.ndarray
    Jq: np.ndarray
    grow: np.ndarray
    tau: np.ndarray | None
    point: np.ndarray
    flange_R: np.ndarray
    delta_twin: np.ndarray
    rec: np.ndarray
    t_s: np.ndarray | None
    temp_c: np.ndarray | None
    dir_q: np.ndarray | None
    dir_motor: np.ndarray | None
    tool: np.ndarray | None
    flex: dict[int, np.ndarray] | None
    followers: tuple[int, ...]


# --- the arm --------------------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class Geometry(Effect):
    """Kinematic parameter errors of the chain (its identifiable combinations), about the
    twin's."""

    name: str = "geometry"
    axis: str = "xyz"
    kept: tuple[int, ...] = ()
    names: tuple[str, ...] = ()
    # fit's prior on the kinematic errors (zero mean, a machined arm's tolerances), as the
    # engine's prior rows: the signal's noise over each error's prior std (() for none)
    prior_weight: tuple[float, ...] = ()

    def __post_init__(self):
        object.__setattr__(self, "needs", ("J",))

    def columns(self, d):
        J = np.asarray(d["J"], float)[:, :, list(self.kept)]
        return J.reshape(3 * len(J), len(self.kept))

    def describe(self, coef, cov):
        angle = {n: n.startswith(("dalpha", "dtheta", "dbeta")) for n in self.names}
        params = {n: float(c) for n, c in zip(self.names, coef)}
        stderr = {n: coef_std(cov, i) for i, n in enumerate(self.names)}
        big = sorted(params, key=lambda n: -abs(params[n]) / max(stderr[n], 1e-300))[:3]
        return (
            params,
            stderr,
            "the arm's link lengths, offsets and twists differ from the drawing (largest: "
            + ", ".join(
                f"{n} {params[n] * (1e6 if angle[n] else 1000):+.0f} {'urad' if angle[n] else 'um'}"
                for n in big
            )
            + ")",
        )


def joint_column(d: Drivers, joint: int) -> np.ndarray:
    """d(point) / d(q_joint), (n, 3): how a turn of the joint moves the measured point."""
    return np.asarray(d["Jq"], float)[:, :, joint - 1]


@dataclasses.dataclass(frozen=True)
class JointEffect(Effect):
    """Base of the arm's effects that act on one joint's angle: keyed by the joint."""

    axis: str = "xyz"
    joint: int = 1

    @property
    def key(self) -> str:
        """The effect's name, axis and joint: one candidate per joint."""
        return f"{self.name}:joint{self.joint}"


@dataclasses.dataclass(frozen=True)
class EncoderEccentricity(JointEffect):
    """A once-per-turn angle error of joint j: dq = A sin(q + phase) (the reading is off)."""

    name: str = "encoder_eccentricity"

    def __post_init__(self):
        object.__setattr__(self, "needs", ("Jq", "q"))

    def columns(self, d):
        q = np.asarray(d["q"], float)[:, self.joint - 1]
        Jt = joint_column(d, self.joint)
        # the true angle is the reading minus the error: p moves by -J dq
        return -np.stack(
            [(Jt * np.sin(q)[:, None]).ravel(), (Jt * np.cos(q)[:, None]).ravel()], axis=1
        )

    def describe(self, coef, cov):
        amp, amp_std, phase = amplitude(
            *coef, cov
        )  # A sin(q + ph) = A cos(ph) sin q + A sin(ph) cos q
        return (
            {"joint": self.joint, "amplitude_urad": amp * 1e6, "phase_rad": phase},
            {"amplitude_urad": amp_std * 1e6},
            f"joint {self.joint}'s encoder reads {amp * 1e6:.0f} urad off once per turn: its disc "
            f"is mounted off-centre (eccentricity)",
        )


@dataclasses.dataclass(frozen=True)
class Transmission(JointEffect):
    """Joint j's angle error periodic in its own angle beyond once per turn: dq = a sin(h q) +
    b cos(h q), ``harmonic`` h in cycles per turn of the joint (gear and encoder harmonics need
    not be whole numbers of the joint's turn)."""

    name: str = "transmission"
    harmonic: float = 2.0
    harmonic_std: float = 0.0
    # its own amplitude and phase in each recording (``rec`` (n,) among the drivers): a motor-side
    # error, whose phase to the joint's angle is set anew at each power-up
    per_recording: bool = False

    def __post_init__(self):
        object.__setattr__(self, "needs", ("Jq", "q", "rec") if self.per_recording else ("Jq", "q"))

    @property
    def key(self) -> str:
        """One shared and one per-recording transmission per joint."""
        return f"{self.name}:joint{self.joint}" + (":per_recording" if self.per_recording else "")

    def columns(self, d):
        q = np.asarray(d["q"], float)[:, self.joint - 1]
        Jt = joint_column(d, self.joint)
        h = self.harmonic * q
        cols = -np.stack(
            [(Jt * np.sin(h)[:, None]).ravel(), (Jt * np.cos(h)[:, None]).ravel()], axis=1
        )
        if not self.per_recording:
            return cols
        rec = np.repeat(np.asarray(d["rec"], int), Jt.shape[1])
        return np.concatenate(
            [cols * (rec == r)[:, None] for r in range(int(rec.max()) + 1)], axis=1
        )

    # the std of a session's correction, as register_session's (fit.session_residuals)
    session_prior = SESSION_PRIOR_RAD

    @property
    def session_refit(self) -> bool:
        """A shared harmonic's phase may be set anew at a power-up: a new session refits it on
        its registration rows (fit's :func:`~calibench.estimators.arm.session.session_terms`)."""
        return not self.per_recording

    def describe(self, coef, cov):
        parts = [
            amplitude(*coef[k : k + 2], cov[k : k + 2, k : k + 2]) for k in range(0, len(coef), 2)
        ]
        amp, amp_std, phase = parts[0]
        params = {
            "joint": self.joint,
            "harmonics": [self.harmonic],
            "amplitude_urad": [amp * 1e6],
            "phase_rad": [phase],
        }
        stds = {"amplitude_urad": [amp_std * 1e6], "harmonics": [self.harmonic_std]}
        words = (
            f"joint {self.joint}'s angle is {amp * 1e6:.0f} urad off {self.harmonic:.2f} times "
            f"per turn: a harmonic of its gear train or encoder"
        )
        if self.per_recording:
            # amplitude_urad stays one per harmonic (docs/formats.md): the recordings' RMS amplitude
            amps, amp_stds = [a * 1e6 for a, _, _ in parts], [a_std * 1e6 for _, a_std, _ in parts]
            del params["phase_rad"]  # no phase the recordings share
            params.update(
                per_recording=True,
                amplitude_urad=[float(np.sqrt(np.mean(np.square(amps))))],
                amplitude_urad_by_recording=amps,
                phase_rad_by_recording=[ph for _, _, ph in parts],
            )
            # first order, amplitudes of about one size: the RMS of R independent ones
            stds.update(
                amplitude_urad=[float(np.sqrt(np.mean(np.square(amp_stds)) / len(amps)))],
                amplitude_urad_by_recording=amp_stds,
            )
            words = (
                f"joint {self.joint}'s angle is {min(amps):.0f}-{max(amps):.0f} urad off "
                f"{self.harmonic:.2f} "
                "times per turn with a phase of its own in each recording: a harmonic of the "
                f"motor's side of its gear train, whose phase is set at power-up"
            )
        return params, stds, words


@dataclasses.dataclass(frozen=True)
class TransmissionSearch:
    """A transmission candidate whose harmonic is found on the data it is fitted to
    (:func:`best_harmonic`): fixed by :meth:`fix` on the training rows."""

    joint: int
    harmonics: np.ndarray
    axis: str = "xyz"
    name: str = "transmission"
    # one harmonic, its amplitude and phase per recording (:class:`Transmission`)
    per_recording: bool = False

    takes_basis = True  # fix may be given others[rows]'s orthonormal basis (fit.cv_residuals)
    session_prior = SESSION_PRIOR_RAD  # as the harmonic it fixes

    @property
    def session_refit(self) -> bool:
        """As the harmonic it fixes (:attr:`Transmission.session_refit`)."""
        return not self.per_recording

    @property
    def key(self) -> str:
        """The search's name and joint: one shared and one per-recording search per joint."""
        return f"{self.name}:joint{self.joint}" + (":per_recording" if self.per_recording else "")

    def applies(self, drivers) -> bool:
        """A per-recording search needs several recordings."""
        rec = drivers.get("rec")
        return not self.per_recording or (rec is not None and len(np.unique(rec)) > 1)

    def fix(
        self,
        r: np.ndarray,
        others: np.ndarray,
        rows: np.ndarray,
        drivers: Drivers,
        basis: np.ndarray | None = None,
    ) -> Transmission:
        """The best harmonic on rows ``rows`` (bool over the signal's rows) beside ``others``;
        ``basis``: an orthonormal basis of ``others[rows]`` when the caller has one."""
        q = np.asarray(drivers["q"], float)[:, self.joint - 1]
        Jt = joint_column(drivers, self.joint)
        groups = np.asarray(drivers["rec"], int) if self.per_recording else None
        h, h_std = best_harmonic(q, Jt, r, others, self.harmonics, rows, groups=groups, basis=basis)
        return Transmission(
            joint=self.joint, harmonic=h, harmonic_std=h_std, per_recording=self.per_recording
        )


@dataclasses.dataclass(frozen=True)
class JointTable(JointEffect):
    """``nonsmooth`` on an arm: joint j's angle error as a free value in each band of its angle
    (``edges`` (k + 1,) rad), for structure no candidate explains: a lookup table, not a law."""

    name: str = "nonsmooth"
    edges: tuple = ()
    span: tuple = (-np.pi, np.pi)  # the angles the data cover, for the words
    # what no law explains need not hold in another session as it did in these: a new session
    # refits the bands its registration rows reach, held to the others' values by the prior
    session_refit = True
    session_prior = SESSION_PRIOR_RAD

    def __post_init__(self):
        object.__setattr__(self, "needs", ("Jq", "q"))

    def bands(self, q_joint: np.ndarray) -> np.ndarray:
        """Which band of the table each angle falls in, (n,) int, for the joint's angles
        ``q_joint`` (n,) rad."""
        return np.clip(
            np.searchsorted(self.edges, q_joint, side="right") - 1, 0, len(self.edges) - 2
        )

    def columns(self, d):
        q = np.asarray(d["q"], float)[:, self.joint - 1]
        Jt = joint_column(d, self.joint)
        X = np.zeros((len(q), 3, len(self.edges) - 1))
        X[np.arange(len(q)), :, self.bands(q)] = -Jt
        return X.reshape(-1, len(self.edges) - 1)

    def describe(self, coef, cov):
        coef = coef - coef.mean()  # a common part is a zero offset, which the geometry has
        k = int(np.argmax(np.abs(coef)))
        lo, hi = np.degrees(np.clip(self.edges[k : k + 2], *self.span))
        where = f"as a function of q{self.joint}, largest at {lo:.0f} to {hi:.0f} deg"
        edges = [float(e) for e in np.degrees(self.edges[1:-1])]
        return (
            {
                "joint": self.joint,
                "where": where,
                "peak_urad": float(coef[k]) * 1e6,
                "edges_deg": edges,
            },
            {"peak_urad": coef_std(cov, k) * 1e6},
            f"joint {self.joint}'s angle error varies with its angle in a way no candidate "
            f"explains ({where}, {coef[k] * 1e6:+.0f} urad): modelled as a table over its angle",
        )


def joint_table(
    q_joint: np.ndarray, joint: int, min_rows: int = 30, max_bands: int = 16
) -> JointTable | None:
    """Bands of equal counts over the joint's angles (at least ``min_rows`` each), or None."""
    k = min(max_bands, len(q_joint) // min_rows)
    if k < 3 or np.ptp(q_joint) < 1e-3:
        return None
    edges = np.unique(np.quantile(q_joint, np.linspace(0, 1, k + 1)))
    if len(edges) < 4:
        return None
    span = (float(edges[0]), float(edges[-1]))
    edges[0], edges[-1] = -np.inf, np.inf
    return JointTable(joint=joint, edges=tuple(edges), span=span)


@dataclasses.dataclass(frozen=True)
class ArmThermalExpansion(Effect):
    """Every link length grows by k (T - T_mean): the chain's a and d and the tool scaled
    together (``grow`` (5 N + 3,) the lengths in delta's layout, zeros at the angles)."""

    name: str = "thermal_expansion"
    axis: str = "xyz"

    def __post_init__(self):
        object.__setattr__(self, "needs", ("J", "temp_c", "grow"))

    def applies(self, drivers):
        T = drivers.get("temp_c")
        return (
            drivers.get("J") is not None
            and drivers.get("grow") is not None
            and T is not None
            and np.ptp(T) > 0
        )

    def columns(self, d):
        J = np.asarray(d["J"], float)
        T = np.asarray(d["temp_c"], float)
        return ((J @ np.asarray(d["grow"], float)) * ((T - T.mean()) * 1e-6)[:, None]).reshape(
            -1, 1
        )

    def describe(self, coef, cov):
        k = float(coef[0])
        return (
            {"ppm_per_k": k},
            {"ppm_per_k": coef_std(cov, 0)},
            f"the links grow {k:.1f} ppm per kelvin of the logged temperature: thermal growth of "
            "the arm",
        )


@dataclasses.dataclass(frozen=True)
class ArmDrift(Effect):
    """The measured points drift as a whole, wherever the arm is: the instrument's stand or the
    arm's base growing with the logged temperature (mm/K, ``driver`` ``temp_c``), or with time
    (``t_s``: a slope in mm/h at mid-recording and a bend in mm/h^2, a warm-up is no straight
    line). Each recording drifts about its own mean (its own frame takes the rest)."""

    name: str = "thermal_drift"
    axis: str = "xyz"
    driver: str = "temp_c"

    def __post_init__(self):
        object.__setattr__(self, "needs", (self.driver, "rec"))

    @property
    def key(self) -> str:
        """One candidate per driver."""
        return f"thermal_drift:{self.driver}"

    def applies(self, drivers):
        v = drivers.get(self.driver)
        return v is not None and np.ptp(np.asarray(v, float)) > 0

    def _centred(self, d) -> np.ndarray:
        v = np.asarray(d[self.driver], float) / (3600 if self.driver == "t_s" else 1)
        rec = np.asarray(d["rec"])
        ids = np.unique(rec, return_inverse=True)[1].reshape(-1)
        return v - (np.bincount(ids, v) / np.bincount(ids))[ids]

    def columns(self, d):
        v = self._centred(d)
        shapes = [v] if self.driver == "temp_c" else [v, v**2 - np.mean(v**2)]
        # (n, 3, 3 k): each shape along x, y and z in turn, stacked posture by posture
        cols = np.einsum("nk,ij->nikj", np.stack(shapes, axis=1), np.eye(3))
        return cols.reshape(3 * len(v), 3 * len(shapes))

    @property
    def unit(self) -> str:
        """The slope's unit: mm per kelvin (temperature) or mm per hour (time)."""
        return "mm_per_h" if self.driver == "t_s" else "mm_per_k"

    def describe(self, coef, cov):
        params, stderr, slope = drift_vector(coef, cov, self.unit)
        k = params[self.unit]
        per = "hour at mid-recording" if self.driver == "t_s" else "kelvin of the logged air"
        return (
            params,
            stderr,
            f"the measured points drift {k * 1000:.2f} um per {per}, wherever the arm is "
            f"(x {slope[0] * 1000:+.2f}, y {slope[1] * 1000:+.2f}, z {slope[2] * 1000:+.2f} um): "
            "the instrument's stand or the arm's base moving, not the arm's geometry",
        )
