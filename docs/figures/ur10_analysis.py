"""The real UR10's residuals analysed: the periodogram of what the physics model leaves out, the
error after large moves, one phase or a phase per session for the gear harmonics, the issue's
targets, and the discovery on C effect by effect."""

from __future__ import annotations

import functools
import json
import re

from .engine import ROOT, block
from .fmt import span, words
from .runner import UR10, judged, ur10_discovery_c, ur10_fit, ur10_residuals
from .ur10_fit import ALL, GEAR, GEAR_Q2, H17, SHOULDER, gear_q2_is_current, table_joints

PERIODOGRAM_JOINTS = (1, 2, 3)  # the joints whose angle errors share one frequency
LARGE_MOVE_DEG = 60  # a row after a larger move of any joint is "after a large move"
NEAR_ROWS = 5  # training rows within this many rows of the worst held-out row are "beside it"
# the issue's targets on C's held-out rows (mm): the mean, the max, and the mean it aims at
TARGET_MEAN_MM, TARGET_MAX_MM, AIM_MEAN_MM = 0.40, 1.3, 0.25


@functools.cache
def periodogram_peaks() -> dict:
    """For each series, the physics fit's residuals (training and held-out rows) through
    estimators.arm.residuals' periodogram on PERIODOGRAM_JOINTS at 5 to 30 cycles per turn in
    steps of 0.01: {file: (frequency of the largest gain, amplitudes there (k,) mrad)}."""
    import numpy as np

    from calibench.estimators.arm.residuals import (
        angle_jacobian,
        harmonic_amplitude_phase,
        joint_angle_periodogram,
    )
    from calibench.estimators.rotations import rotvec_to_matrix
    from calibench.recordings import load_arm_csv
    from calibench.scenarios.arm_cmm.arms import chain_of, load_arm

    chain = chain_of(load_arm(UR10 / "ur10.toml"))
    fit, res = ur10_fit("all"), ur10_residuals("all")
    freqs = np.arange(500, 3001) / 100  # exactly the hundredths from 5 to 30
    cols = [j - 1 for j in PERIODOGRAM_JOINTS]
    out = {}
    for name in ALL:
        rows, roles, e = res[name]
        use = np.isin(roles, ("train", "holdout"))
        q = load_arm_csv(UR10 / name, n_joints=6).q_rad[rows[use]]
        R = rotvec_to_matrix(np.array(fit["bases"][name]["rotvec_rad"]))
        jac = angle_jacobian(chain, q, PERIODOGRAM_JOINTS, R)
        gain, coef = joint_angle_periodogram(jac, e[use], q[:, cols], freqs)
        k = int(np.argmax(gain))
        out[name] = (freqs[k], 1e3 * harmonic_amplitude_phase(coef[k])[0])
    return out


@block(seconds=30, ci=True)
def ur10_periodogram():
    """The physics fit on all four series (training and held-out rows of residuals.csv) against
    one joint-angle error at a common frequency on joints 1-3: a sine and a cosine per joint
    through the arm's joint Jacobian, fitted at every frequency from 5 to 30 cycles per turn in
    steps of 0.01; where the fit gains most, and the amplitudes there."""
    import numpy as np

    peaks = periodogram_peaks()
    abd = ["ur10_A.csv", "ur10_B.csv", "ur10_D.csv"]
    amps = np.concatenate([peaks[c][1] for c in abd])
    letters = words([c.removeprefix("ur10_").removesuffix(".csv") for c in abd])
    return (
        f"What the physics model leaves out shows in its residuals with nearly one frequency: "
        f"fitted as one joint-angle error at a common frequency on joints "
        f"{words(map(str, PERIODOGRAM_JOINTS))} (a sine and a cosine per joint, through the "
        f"arm's Jacobian; `residuals.csv` of the physics fit on all four, training and held-out "
        f"rows), {letters} gain most at {words([f'{peaks[c][0]:.2f}' for c in abd])} cycles per "
        f"turn, C at {peaks['ur10_C.csv'][0]:.2f}; the amplitudes there are "
        f"{span(amps, '.2f')} mrad on {letters}."
    )


@block(seconds=5, ci=True)
def ur10_after_moves():
    """The per-session gear-harmonic fit's held-out rows of A and D (residuals.csv): A's largest,
    the training rows beside it the fit left out, and the error after the robot's largest moves."""
    import numpy as np

    from calibench.estimators.arm.residuals import error_after_moves, largest_joint_move_deg
    from calibench.recordings import load_arm_csv

    res = ur10_residuals("all", GEAR)
    rows, roles, e = res["ur10_A.csv"]
    err = np.linalg.norm(e, axis=1)
    k = int(np.argmax(np.where(roles == "holdout", err, -1)))
    worst = int(rows[k])
    near = sorted(int(r) for r in rows[(roles == "left_out") & (np.abs(rows - worst) <= NEAR_ROWS)])
    after = {}
    for name in ("ur10_A.csv", "ur10_D.csv"):
        rows, roles, e = res[name]
        move = largest_joint_move_deg(load_arm_csv(UR10 / name, n_joints=6).q_rad)[rows]
        held = roles == "holdout"
        after[name] = error_after_moves(np.linalg.norm(e, axis=1)[held], move[held], LARGE_MOVE_DEG)
    a, d = after["ur10_A.csv"], after["ur10_D.csv"]
    beside = (
        f"; the training rows {words(map(str, near))} beside it the fit leaves out as beyond its "
        "scatter"
        if near
        else ""
    )
    return (
        f"A's largest held-out error is row {worst}{beside}. The held-out residuals grow after "
        f"the robot's largest moves: mean {a[0]:.2f} mm after a move of more than "
        f"{LARGE_MOVE_DEG} degrees (of any joint, from the row before) against {a[1]:.2f} mm "
        f"after smaller ones in A, {d[0]:.2f} against {d[1]:.2f} mm in D."
    )


@block(seconds=45, ci=True)
def ur10_one_phase():
    """calibench fit arm-cmm on all four, --holdout 0.3, without and with --effects
    docs/ur10_harmonic17.json (one phase for all series)."""
    plain = ur10_fit("all")["holdout"]
    h17, inside = judged(ur10_fit("all", H17))
    order = ("ur10_A.csv", "ur10_D.csv", "ur10_B.csv", "ur10_C.csv")
    better = [c for c in order if h17[c]["mean_mm"] < plain[c]["mean_mm"]]
    worse = [c for c in order if c not in better]
    moves = [
        f"{c[5]} from {plain[c]['mean_mm']:.3f} to {h17[c]['mean_mm']:.3f}" for c in better + worse
    ]
    if moves:
        moves[0] += " mm"
    text = (
        f"With one phase for all series (`--effects {H17}`) it brings {words(moves[: len(better)])}"
        + (" (in-sample: the harmonic was chosen on those rows too)" if inside else "")
    )
    if worse:
        text += (
            f", but {words(moves[len(better) :])}: {words([c[5] for c in worse])}'s phase differs"
        )
    return text + "."


@block(seconds=200, ci=True)
def ur10_per_session():
    """calibench fit arm-cmm on all four, --holdout 0.3 --effects docs/ur10_gear_harmonics.json;
    which of its harmonics the periodograms show and which the discovery on C found."""
    spec = json.loads((ROOT / GEAR).read_text())
    harmonics = sorted({h for e in spec["effects"] for h in e["params"]["harmonics"]})
    joints = sorted(e["params"]["joint"] for e in spec["effects"])
    # a harmonic is a whole number of cycles per turn: the nearest to a peak or a discovered one
    seen = sorted(
        {h for h in harmonics if any(round(f) == h for f, _ in periodogram_peaks().values())}
    )
    found = {
        round(f)
        for e in ur10_discovery_c()["effects"]
        if e["name"] == "transmission"
        for f in e["params"]["harmonics"]
    }
    discovered = sorted(h for h in harmonics if h in found and h not in seen)
    held, inside = judged(ur10_fit("all", GEAR))
    scored = "in-sample" if inside else "held-out"
    worst = max(ALL, key=lambda c: held[c]["max_mm"])
    rest = max(held[c]["max_mm"] for c in ALL if c != worst)
    return (
        f"`{GEAR}` holds {words(map(str, harmonics))} cycles per turn on joints "
        f"{joints[0]}-{joints[-1]} ({words(map(str, seen))} from the periodograms, "
        f"{words(map(str, discovered))} from discovery on C): every {scored} mean falls to "
        f"{span([held[c]['mean_mm'] for c in ALL], '.2f')} mm and every max but {worst[5]}'s to "
        f"{rest:.2f} mm or less; {worst[5]}'s is {held[worst]['max_mm']:.2f} mm."
    )


@block(seconds=90, ci=True)
def ur10_targets():
    """The issue's targets (0.40 mm mean, 1.3 mm max on C; 0.25 mm the aim) against the physics
    fit on all four (and on all of C, its floor there), the fit with per-session gear harmonics,
    and with those and the table over q2."""
    gear_q2_is_current()
    mean_t, max_t, aim = TARGET_MEAN_MM, TARGET_MAX_MM, AIM_MEAN_MM
    c = ur10_fit("all")["holdout"]["ur10_C.csv"]
    # C's own rows, all of them fitted: what held-out rows of C could at best average
    c_itself = ur10_fit("C", model="physics")["fit"]["mean_mm"]
    held, inside = judged(ur10_fit("all", GEAR))
    at = "is at" if c["mean_mm"] <= mean_t and c["max_mm"] <= max_t else "is not at"
    floor = (
        f", and cannot be: fitted to all of C's rows, none held out, it leaves them "
        f"{c_itself:.3f} mm on average, so C's held-out rows cannot be expected to average "
        f"{mean_t:.2f}"
        if c_itself > mean_t
        else ""
    )
    under = [x for x in ALL if held[x]["mean_mm"] < mean_t]
    over = [x for x in ALL if held[x]["max_mm"] >= max_t]
    means = "every series is" if len(under) == len(ALL) else f"{words([x[5] for x in under])} are"
    maxes = f"every max under {max_t} mm" + (
        f" but {words([x[5] + chr(39) + 's' for x in over])} "
        f"({words([format(held[x]['max_mm'], '.2f') for x in over])})"
        if over
        else ""
    )
    a = held["ur10_A.csv"]["mean_mm"]
    q2, inside_q2 = judged(ur10_fit("all", GEAR_Q2))
    worst = max(ALL, key=lambda x: q2[x]["max_mm"])
    # at the aim as printed: within half the last of the three decimals
    at_aim = [x[5] for x in ALL if q2[x]["mean_mm"] <= aim + 0.0005]
    return (
        f"Where that leaves the issue's targets: the physics model alone {at} {mean_t:.2f} / "
        f"{max_t} mm on C ({c['mean_mm']:.3f} / {c['max_mm']:.2f}){floor}; with the per-session "
        f"gear harmonics{' (in-sample)' if inside else ''} {means} under {mean_t:.2f} mm mean "
        f"and {maxes}, and A is "
        f"{'under' if a < aim else 'not under'} the {aim} mm aim. With the table over "
        f"{table_joints(GEAR_Q2)} besides{' (in-sample)' if inside_q2 else ''}, the means are "
        f"{span([q2[x]['mean_mm'] for x in ALL], '.3f')} mm ({words(at_aim) if at_aim else 'none'} "
        f"at the {aim} mm aim) and the largest max is {worst[5]}'s, {q2[worst]['max_mm']:.4f} mm "
        f"({'over' if q2[worst]['max_mm'] > max_t else 'within'} the {max_t} mm)."
    )


@block(seconds=75, ci=True)
def ur10_discovery():
    """calibench discover arm-cmm ur10_C.csv --arm ur10.toml: the held-out RMS, effect by effect."""
    d = ur10_discovery_c()
    # a run of gear harmonics reads as one step: "of joint 2 (...), of joint 1 (...)"
    steps, gears = [], []
    for e in d["effects"] + [{"name": "end"}]:
        p = e.get("params", {})
        um = f"{e['cv_rms_after'] * 1000:.0f} um" if "cv_rms_after" in e else ""
        if e["name"] == "transmission":
            amp = p["amplitude_urad"]
            amp = max(amp) if isinstance(amp, list) else amp
            unit = " cycles per turn" if not gears else ""
            gears.append(
                f"of joint {p['joint']} ({amp:.0f} urad, {p['harmonics'][0]:.2f}{unit}) {um}"
            )
            continue
        if gears:
            steps.append("gear harmonics " + words(gears))
            gears = []
        if e["name"] == "geometry":
            steps.append(f"with its geometry {um}")
        elif e["name"] == "nonsmooth":
            where = re.sub(r"^as a function of q\d+, ", "", p["where"])
            steps.append(
                f"a table over joint {p['joint']}'s angle (nonsmooth: {where}, "
                f"{p['peak_urad']:+.0f} urad) {um}"
            )
        elif e["name"] != "end":
            steps.append(f"{e['name'].replace('_', ' ')} of joint {p.get('joint')} {um}")
    comp = [c for c in d["confounded"] if c["effect"] == "joint_compliance"]
    joints = [re.search(r"joint (\d+)'s", c["why"]).group(1) for c in comp]
    absorbed = [int(re.search(r"(\d+) % of a compliance", c["why"]).group(1)) for c in comp]
    torque = next(
        (
            re.search(
                r"\((-?[\d.]+(?:e[+-]?\d+)?) to (-?[\d.]+(?:e[+-]?\d+)?) N m\)", c["why"]
            ).groups()
            for c in comp
            if f"joint {SHOULDER}'s" in c["why"]
        ),
        None,
    )
    text = (
        f"(held-out RMS per coordinate, {d['holdout']}): the drawing's UR10 "
        f"{d['fit']['cv_rms_nominal'] * 1000:.0f} um; {'; '.join(steps)}."
    )
    if comp:
        held_torque = ""
        if torque:
            lo, hi = torque
            held_torque = f" (C holds joint {SHOULDER}'s torque at {lo} to {hi} N m)"
        text += (
            f" The compliances of joints {words(joints)} are not claimed from C alone, and "
            f"discovery says why in words: within C's poses the geometry absorbs "
            f"{span(absorbed, 'd')} % of their effect{held_torque}, though compliance is what "
            f"carries the fit to the other series."
        )
    return text
