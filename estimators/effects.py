"""Candidate effects: physical terms a simulation may have left out, each with units and bounds.

One small interface, many small implementations (CONTRACT's vocabulary). An effect is linear in
its coefficients once its shape is fixed: ``columns(drivers) -> (n, k)`` in the signal's unit
(mm), ``describe(coef, cov) -> (params, stderr, physics)``. Shapes with a nonlinear parameter (a
period) are fixed by :func:`best_period` on the data they are fitted to.

``drivers`` is a plain dict of (n,) arrays: ``x``, ``y`` (commanded, mm), ``dir_x``, ``dir_y``
(+1 / -1 / 0), ``t_s``, ``temp_c``, ``run`` for stages; for an N-joint arm ``q`` (n, N) rad,
``J`` (n, 3, 5 N + 3) the chain's parameter Jacobian, ``Jq`` (n, 3, N) d(point) / d(q),
``tau`` (n, N) the joints' gravity torques (N m, from the twin), ``grow`` (5 N + 3,) the chain's
lengths in the Jacobian's layout. A missing driver means the candidate does not apply
(``applies`` is False). Searched shapes (a transmission's harmonic) are fixed by their
``fix(r, others, rows, drivers)`` on the rows they are fitted to.
"""

from __future__ import annotations

import dataclasses
import functools

import numpy as np

AXES = ("x", "y")


@dataclasses.dataclass(frozen=True)
class Effect:
    """Base: a name from the vocabulary, the signal it acts on (``axis``: x, y or xyz), the
    drivers it needs."""

    name: str = ""
    axis: str = "x"
    needs: tuple[str, ...] = ()

    @property
    def key(self) -> str:
        """A name that tells this candidate apart from the others of its kind (for de-duplication)."""
        return f"{self.name}:{self.axis}"

    def applies(self, drivers: dict) -> bool:
        """Whether the recording carries what this effect needs (its drivers: directions, temperatures, ...)."""
        return all(
            drivers.get(k) is not None and np.ptp(np.asarray(drivers[k], float)) > 0
            for k in self.needs
        )

    def columns(self, drivers: dict) -> np.ndarray:
        """The effect's design matrix on the recording's rows, (n, k): one column per parameter, in the signal's unit
        per parameter unit."""
        raise NotImplementedError

    def describe(self, coef: np.ndarray, cov: np.ndarray) -> tuple[dict, dict, str]:
        """The effect in words and physical units, from its fitted coefficients (k,): what discover prints."""
        raise NotImplementedError


def _std(cov, i):
    return float(np.sqrt(max(cov[i, i], 0.0)))


def _amplitude(s: float, c: float, cov: np.ndarray) -> tuple[float, float, float]:
    """Amplitude, its std (first order) and phase of s sin + c cos."""
    amp = float(np.hypot(s, c))
    g = np.array([s, c]) / max(amp, 1e-300)  # d amp / d (s, c)
    return amp, float(np.sqrt(max(g @ cov[:2, :2] @ g, 0.0))), float(np.arctan2(c, s))


@dataclasses.dataclass(frozen=True)
class Backlash(Effect):
    """Lost motion on reversal: +B/2 approaching forward, -B/2 backward. With ``span_mm`` (the
    axis's measured range, lo and hi) B grows along the travel, ``B(u) = B0 + g u``, as an
    elastic drive's does (a belt whose free span lengthens with the position)."""

    name: str = "backlash"
    span_mm: tuple[float, float] | None = None

    def __post_init__(self):
        object.__setattr__(
            self, "needs", (f"dir_{self.axis}",) + ((self.axis,) if self.span_mm else ())
        )

    @property
    def key(self) -> str:
        return f"backlash:{self.axis}" + (":grows" if self.span_mm else "")

    def columns(self, d):
        half = np.asarray(d[f"dir_{self.axis}"], float) / 2
        if self.span_mm is None:
            return half[:, None]
        return np.stack([half, half * np.asarray(d[self.axis], float) / 1000], axis=1)

    def describe(self, coef, cov):
        a = self.axis.upper()
        if self.span_mm is None:
            B = float(coef[0])
            return (
                {"reversal_mm": B},
                {"reversal_mm": _std(cov, 0)},
                f"lost motion on reversal of the {a} drive: {B * 1000:+.1f} um between the two "
                f"directions of approach (+B/2 approaching forward, -B/2 backward)",
            )
        lo, hi = self.span_mm
        mid = np.array([1.0, (lo + hi) / 2000])  # B at the middle of the measured travel
        B0, g = float(coef[0]), float(coef[1])
        params = {
            "reversal_mm": float(mid @ coef[:2]),
            "reversal_at_home_mm": B0,
            "growth_mm_per_m": g,
            "reversal_at_start_mm": B0 + g * lo / 1000,
            "reversal_at_end_mm": B0 + g * hi / 1000,
        }
        stderr = {
            "reversal_mm": float(np.sqrt(max(mid @ cov[:2, :2] @ mid, 0.0))),
            "reversal_at_home_mm": _std(cov, 0),
            "growth_mm_per_m": _std(cov, 1),
        }
        return (
            params,
            stderr,
            f"lost motion on reversal of the {a} drive that grows along the travel: "
            f"{params['reversal_at_start_mm'] * 1000:.1f} um at {self.axis} = {lo:.0f} mm to "
            f"{params['reversal_at_end_mm'] * 1000:.1f} um at {self.axis} = {hi:.0f} mm "
            f"({g * 100:+.1f} um per 100 mm): an elastic drive (a belt whose free span lengthens along the "
            f"travel) against the carriage's friction",
        )


@dataclasses.dataclass(frozen=True)
class Periodic(Effect):
    """A sinusoid in the axis's own position: pulley run-out, belt tooth, lead screw."""

    name: str = "periodic"
    period_mm: float = 0.0
    period_std: float | None = None

    def __post_init__(self):
        object.__setattr__(self, "needs", (self.axis,))

    def columns(self, d):
        ph = 2 * np.pi * np.asarray(d[self.axis], float) / self.period_mm
        return np.stack([np.sin(ph), np.cos(ph)], axis=1)

    def describe(self, coef, cov):
        amp, amp_std, phase = _amplitude(*coef, cov)
        params = {"period_mm": self.period_mm, "amplitude_mm": amp, "phase_rad": phase}
        stderr = {"period_mm": self.period_std, "amplitude_mm": amp_std}
        return (
            params,
            stderr,
            f"a once-per-{self.period_mm:.1f} mm error of the {self.axis.upper()} axis, {amp * 1000:.1f} um "
            f"amplitude: something in the drive turns once every {self.period_mm:.1f} mm of travel (a pulley's or "
            f"screw's run-out, a belt's tooth pattern)",
        )


@dataclasses.dataclass(frozen=True)
class ThermalExpansion(Effect):
    """Scale proportional to the temperature change: e = k (T - T_mean) u, k in ppm/K."""

    name: str = "thermal_expansion"

    def __post_init__(self):
        object.__setattr__(self, "needs", (self.axis, "temp_c"))

    def columns(self, d):
        T = np.asarray(d["temp_c"], float)
        return ((T - T.mean()) * np.asarray(d[self.axis], float) * 1e-6)[:, None]

    def describe(self, coef, cov):
        k = float(coef[0])
        return (
            {"ppm_per_k": k},
            {"ppm_per_k": _std(cov, 0)},
            f"the {self.axis.upper()} scale (or its reference) grows {k:.2f} ppm per kelvin of the logged "
            f"temperature: thermal expansion the simulation does not have",
        )


@dataclasses.dataclass(frozen=True)
class ThermalDrift(Effect):
    """An offset that follows the temperature (mm/K), or time when no temperature is logged."""

    name: str = "thermal_drift"
    driver: str = "temp_c"

    def __post_init__(self):
        object.__setattr__(self, "needs", (self.driver,))

    def columns(self, d):
        v = np.asarray(d[self.driver], float)
        v = v / 3600 if self.driver == "t_s" else v
        return (v - v.mean())[:, None]

    @property
    def unit(self) -> str:
        """The unit of the drift's coefficient: mm per hour (driven by time) or mm per kelvin."""
        return "mm_per_h" if self.driver == "t_s" else "mm_per_k"

    def describe(self, coef, cov):
        k = float(coef[0])
        per = "hour" if self.driver == "t_s" else "kelvin"
        return (
            {self.unit: k},
            {self.unit: _std(cov, 0)},
            f"the whole {self.axis.upper()} axis shifts {k * 1000:+.2f} um per {per}, wherever it is: a drift "
            f"of the reference, not of the scale",
        )


@dataclasses.dataclass(frozen=True)
class Polynomial(Effect):
    """Smooth terms beyond the scene's own model: x^i y^j for each (i, j) in ``powers``.

    Named by what they mean for the signal's axis: terms in the signal's own position are a
    nonlinear ``positioning`` error, terms in the other axis's position only are that axis's
    ``straightness``, mixed terms are ``cross_coupling``.
    """

    name: str = "positioning"
    powers: tuple[tuple[int, int], ...] = ()

    def __post_init__(self):
        object.__setattr__(self, "needs", ("x", "y"))

    def columns(self, d):
        x, y = np.asarray(d["x"], float), np.asarray(d["y"], float)
        sx, sy = (
            max(np.ptp(x), 1e-9),
            max(np.ptp(y), 1e-9),
        )  # scaled: coefficients in mm at full travel
        return np.stack(
            [((x - x.min()) / sx) ** i * ((y - y.min()) / sy) ** j for i, j in self.powers], axis=1
        )

    def describe(self, coef, cov):
        params = {f"x{i}y{j}_mm": float(c) for (i, j), c in zip(self.powers, coef)}
        stderr = {f"x{i}y{j}_mm": _std(cov, k) for k, (i, j) in enumerate(self.powers)}
        what = {
            "positioning": f"the {self.axis.upper()} axis's positioning error bends more than the scene's model "
            f"allows along its own travel",
            "straightness": f"the {self.axis.upper()} reading follows the other axis's position beyond the "
            f"scene's model: that axis's travel is not straight",
            "cross_coupling": f"the {self.axis.upper()} error depends on both positions together beyond the "
            f"scene's model",
        }[self.name]
        return params, stderr, what + " (coefficients: mm at full travel)"


def polynomial_candidates(axis: str, degree: int) -> list[Polynomial]:
    """The next order of smooth terms above a scene model of total ``degree`` in (x, y)."""
    own, other = (0, 1) if axis == "x" else (1, 0)
    n = degree + 1
    terms = {"positioning": [], "straightness": [], "cross_coupling": []}
    for k in (n, n + 1):
        for i in range(k + 1):
            p = (i, k - i)
            if p[other] == 0:
                terms["positioning"].append(p)
            elif p[own] == 0:
                terms["straightness"].append(p)
            elif k == n:
                terms["cross_coupling"].append(p)
    return [Polynomial(name=name, axis=axis, powers=tuple(pw)) for name, pw in terms.items() if pw]


# --- the arm ----------------------------------------------------------------------------------------
@dataclasses.dataclass(frozen=True)
class Geometry(Effect):
    """Kinematic parameter errors of the chain (its identifiable combinations)."""

    name: str = "geometry"
    axis: str = "xyz"
    kept: tuple[int, ...] = ()
    names: tuple[str, ...] = ()

    def __post_init__(self):
        object.__setattr__(self, "needs", ("J",))

    def columns(self, d):
        J = np.asarray(d["J"], float)[:, :, list(self.kept)]
        return J.reshape(3 * len(J), len(self.kept))

    def describe(self, coef, cov):
        angle = {n: n.startswith(("dalpha", "dtheta", "dbeta")) for n in self.names}
        params = {n: float(c) for n, c in zip(self.names, coef)}
        stderr = {n: _std(cov, i) for i, n in enumerate(self.names)}
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


def _joint_column(d: dict, joint: int) -> np.ndarray:
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
        Jt = _joint_column(d, self.joint)
        # the true angle is the reading minus the error: p moves by -J dq
        return -np.stack(
            [(Jt * np.sin(q)[:, None]).ravel(), (Jt * np.cos(q)[:, None]).ravel()], axis=1
        )

    def describe(self, coef, cov):
        amp, amp_std, phase = _amplitude(
            *coef, cov
        )  # A sin(q + ph) = A cos(ph) sin q + A sin(ph) cos q
        return (
            {"joint": self.joint, "amplitude_urad": amp * 1e6, "phase_rad": phase},
            {"amplitude_urad": amp_std * 1e6},
            f"joint {self.joint}'s encoder reads {amp * 1e6:.0f} urad off once per turn: its disc is mounted "
            f"off-centre (eccentricity)",
        )


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
        return (_joint_column(d, self.joint) * (tau * 1e-6)[:, None]).reshape(
            -1, 1
        )  # coefficient: urad / N m

    def describe(self, coef, cov):
        c = float(coef[0])
        stiff = f" (a stiffness of {1e6 / c:.3g} N m / rad)" if c > 0 else ""
        return (
            {"joint": self.joint, "urad_per_nm": c},
            {"urad_per_nm": _std(cov, 0)},
            f"joint {self.joint} gives way under the gravity torque it carries: {c:.3g} urad per N m{stiff}",
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
        Jt = _joint_column(d, self.joint)
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

    def describe(self, coef, cov):
        parts = [
            _amplitude(*coef[k : k + 2], cov[k : k + 2, k : k + 2]) for k in range(0, len(coef), 2)
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
            f"joint {self.joint}'s angle is {amp * 1e6:.0f} urad off {self.harmonic:.2f} times per turn: a "
            f"harmonic of its gear train or encoder"
        )
        if self.per_recording:
            # amplitude_urad stays one per harmonic (the contract's): the recordings' RMS amplitude
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
                f"joint {self.joint}'s angle is {min(amps):.0f}-{max(amps):.0f} urad off {self.harmonic:.2f} "
                f"times per turn with a phase of its own in each recording: a harmonic of the motor's side of "
                f"its gear train, whose phase is set at power-up"
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
    per_recording: bool = (
        False  # one harmonic, its amplitude and phase per recording (:class:`Transmission`)
    )

    @property
    def key(self) -> str:
        """The search's name and joint: one shared and one per-recording search per joint."""
        return f"{self.name}:joint{self.joint}" + (":per_recording" if self.per_recording else "")

    def applies(self, drivers) -> bool:
        """A per-recording search needs several recordings."""
        rec = drivers.get("rec")
        return not self.per_recording or (rec is not None and len(np.unique(rec)) > 1)

    def fix(
        self, r: np.ndarray, others: np.ndarray, rows: np.ndarray, drivers: dict
    ) -> Transmission:
        """The best harmonic on rows ``rows`` (bool over the signal's rows) beside ``others``."""
        q = np.asarray(drivers["q"], float)[:, self.joint - 1]
        Jt = _joint_column(drivers, self.joint)
        groups = np.asarray(drivers["rec"], int) if self.per_recording else None
        h, h_std = best_harmonic(q, Jt, r, others, self.harmonics, rows, groups=groups)
        return Transmission(
            joint=self.joint, harmonic=h, harmonic_std=h_std, per_recording=self.per_recording
        )


def best_harmonic(
    q: np.ndarray,
    Jt: np.ndarray,
    r: np.ndarray,
    base: np.ndarray,
    harmonics: np.ndarray,
    rows: np.ndarray | None = None,
    n_peaks: int = 3,
    groups: np.ndarray | None = None,
) -> tuple[float, float]:
    """The harmonic h (cycles per turn) whose angle error a sin(h q) + b cos(h q), seen through
    ``Jt`` (n, 3), best explains ``r`` (3 n,) beside ``base`` (3 n, p), on ``rows`` (3 n,) bool.
    ``groups`` (n,) int: each group of postures (a recording) gets its own a and b, the harmonic
    being shared; what each group's pair explains is summed (the pairs' coupling through
    ``base`` is left out of the sum, as the grid's ranking leaves it out).

    The grid over ``harmonics`` ranks by the residual's projection alone (the columns are not
    orthogonalised against ``base``: cheap, and the ranking barely moves); the best ``n_peaks``
    are then refined by golden section on the exact criterion. Returns h and a rough std (a
    quarter of the grid's spacing)."""
    rows = np.ones(len(r), bool) if rows is None else rows
    Q = np.linalg.qr(base[rows])[0] if base.shape[1] else np.zeros((int(rows.sum()), 0))
    rr = r[rows] - Q @ (Q.T @ r[rows])
    # A column is lever_i sin(h q_p(i)): the kept rows' sums it enters collapse onto the postures
    # (P sums a posture's rows, weighted by their levers), so a harmonic costs one sine per posture
    # rather than per row: S'rr = sin(h q)' P rr, S'S = sin^2(h q)' P lever, Q'S = (P Q)' sin(h q).
    # rr is orthogonal to Q already, so projecting S off Q changes only its Gram matrix, by a'a.
    from scipy import sparse

    lever = Jt.reshape(-1)[rows]
    posture = np.repeat(np.arange(len(q)), 3)[rows]
    P = sparse.csr_matrix((lever, (posture, np.arange(len(lever)))), shape=(len(q), len(lever)))
    w = P @ rr  # (n,)
    l2 = P @ lever  # (n,)
    PQ = np.asarray(P @ Q)  # (n, p)

    def explained_by(w, l2, PQ, hs: np.ndarray, project: bool, trig=None) -> np.ndarray:
        if trig is None:
            ph = q[:, None] * hs[None, :]  # (n, m)
            sin, cos = np.sin(ph), np.cos(ph)
            trig = sin, cos, sin * sin, cos * cos, sin * cos
        sin, cos, sin2, cos2, sincos = trig
        ss, cc, sc = l2 @ sin2, l2 @ cos2, l2 @ sincos
        sr, cr = w @ sin, w @ cos
        if project and PQ.shape[1]:
            a_s, a_c = PQ.T @ sin, PQ.T @ cos  # (p, m)
            ss, cc, sc = ss - (a_s * a_s).sum(0), cc - (a_c * a_c).sum(0), sc - (a_s * a_c).sum(0)
        det = ss * cc - sc * sc
        ok = det > 1e-9 * np.maximum(ss * cc, 1e-300)
        return np.where(
            ok, (cc * sr * sr - 2 * sc * sr * cr + ss * cr * cr) / np.where(ok, det, 1), 0.0
        )

    # a posture's sums belong to its group alone: each group's share is the sums masked to it
    parts = (
        [(w, l2, PQ)]
        if groups is None
        else [(w * m, l2 * m, PQ * m[:, None]) for m in (groups == g for g in np.unique(groups))]
    )

    def explained(hs: np.ndarray, project: bool, trig=None) -> np.ndarray:
        return sum(explained_by(*part, hs, project, trig) for part in parts)

    def exact(hs: np.ndarray) -> np.ndarray:
        return explained(hs, True)

    grid = np.asarray(harmonics, float)
    score = explained(
        grid, False, _grid_trig(np.ascontiguousarray(q, float).tobytes(), grid.tobytes())
    )
    peaks = [
        k
        for k in range(len(grid))
        if score[k] >= score[max(k - 1, 0)] and score[k] >= score[min(k + 1, len(grid) - 1)]
    ]
    peaks = sorted(peaks, key=lambda k: -score[k])[:n_peaks] or [int(np.argmax(score))]
    step = float(np.median(np.diff(grid))) if len(grid) > 1 else 0.1
    g = (np.sqrt(5) - 1) / 2
    best = (-np.inf, grid[peaks[0]])
    for k in peaks:
        # golden section: each step keeps one inner point and its value, and evaluates one new
        lo, hi = grid[k] - step, grid[k] + step
        a, b = hi - g * (hi - lo), lo + g * (hi - lo)
        ea, eb = exact(np.array([a, b]))
        for _ in range(25):
            if ea > eb:
                hi, b, eb = b, a, ea
                a = hi - g * (hi - lo)
                ea = float(exact(np.array([a]))[0])
            else:
                lo, a, ea = a, b, eb
                b = lo + g * (hi - lo)
                eb = float(exact(np.array([b]))[0])
        h = 0.5 * (lo + hi)
        e = float(exact(np.array([h]))[0])
        if e > best[0]:
            best = (e, h)
    return float(best[1]), step / 4


@functools.lru_cache(maxsize=8)
def _grid_trig(q_bytes: bytes, grid_bytes: bytes) -> tuple[np.ndarray, ...]:
    """sin, cos, sin^2, cos^2 and sin cos of h q for every angle and grid harmonic, (n, m) each:
    the same for every fold and every round of a discovery (only the rows' weights change), so
    computed once per joint's angles and grid."""
    ph = np.frombuffer(q_bytes)[:, None] * np.frombuffer(grid_bytes)[None, :]
    sin, cos = np.sin(ph), np.cos(ph)
    out = (sin, cos, sin * sin, cos * cos, sin * cos)
    for a in out:
        a.flags.writeable = False
    return out


def harmonic_grid(q_joint: np.ndarray, top: float = 60.0) -> np.ndarray:
    """Harmonics 2..top cycles per turn, spaced to resolve the joint's span of angles (a quarter
    of a cycle over the span)."""
    span = max(float(np.ptp(q_joint)), 1e-3)
    step = min(0.25, 0.25 * 2 * np.pi / span)
    return np.arange(1.75, top + 1e-9, step)


@dataclasses.dataclass(frozen=True)
class JointTable(JointEffect):
    """``nonsmooth`` on an arm: joint j's angle error as a free value in each band of its angle
    (``edges`` (k + 1,) rad), for structure no candidate explains: a lookup table, not a law."""

    name: str = "nonsmooth"
    edges: tuple = ()
    span: tuple = (-np.pi, np.pi)  # the angles the data cover, for the words

    def __post_init__(self):
        object.__setattr__(self, "needs", ("Jq", "q"))

    def bands(self, q_joint: np.ndarray) -> np.ndarray:
        """Which band of the table each angle falls in, (n,) int, for the joint's angles ``q_joint`` (n,) rad."""
        return np.clip(
            np.searchsorted(self.edges, q_joint, side="right") - 1, 0, len(self.edges) - 2
        )

    def columns(self, d):
        q = np.asarray(d["q"], float)[:, self.joint - 1]
        Jt = _joint_column(d, self.joint)
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
            {"peak_urad": _std(cov, k) * 1e6},
            f"joint {self.joint}'s angle error varies with its angle in a way no candidate explains ({where}, "
            f"{coef[k] * 1e6:+.0f} urad): modelled as a table over its angle",
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
            {"ppm_per_k": _std(cov, 0)},
            f"the links grow {k:.1f} ppm per kelvin of the logged temperature: thermal growth of the arm",
        )


def stage_candidates(drivers: dict) -> list[Effect]:
    """Every stage candidate that the recording's columns can support (periodic added by the
    caller once its period is found)."""
    out = []
    for a in AXES:
        out += [Backlash(axis=a), ThermalExpansion(axis=a), ThermalDrift(axis=a, driver="temp_c")]
        if drivers.get("temp_c") is None:
            out.append(ThermalDrift(axis=a, driver="t_s"))
    return [e for e in out if e.applies(drivers)]


def best_period(
    u: np.ndarray, r: np.ndarray, base: np.ndarray, periods: np.ndarray
) -> tuple[float, float]:
    """The period (mm) whose sinusoid in ``u`` (n,) best explains ``r`` (n,) beside the columns
    ``base`` (n, p), and the fraction of r's variance it explains: a least-squares periodogram
    (Lomb-Scargle with the baseline floating), vectorised over ``periods`` (m,)."""
    Q, _ = np.linalg.qr(base)
    r_perp = r - Q @ (Q.T @ r)
    ph = 2 * np.pi * u[:, None] / periods[None, :]  # (n, m)
    S, C = np.sin(ph), np.cos(ph)
    S -= Q @ (Q.T @ S)
    C -= Q @ (Q.T @ C)
    ss, cc, sc = (S * S).sum(0), (C * C).sum(0), (S * C).sum(0)
    sr, cr = S.T @ r_perp, C.T @ r_perp
    det = ss * cc - sc * sc
    ok = det > 1e-9 * np.maximum(ss * cc, 1e-300)
    explained = np.where(
        ok, (cc * sr * sr - 2 * sc * sr * cr + ss * cr * cr) / np.where(ok, det, 1), 0.0
    )
    k = int(np.argmax(explained))
    return float(periods[k]), float(explained[k] / max(r_perp @ r_perp, 1e-300))
