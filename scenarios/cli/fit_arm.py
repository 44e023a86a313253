"""``calibench fit arm-cmm``: the arm's calibration on its training recordings, its figures on
held-out rows and on recordings it never saw, and ``--leave-one-out``'s sessions."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from calibench.scenarios.cli.status import EXIT_CHECK_FAILED, EXIT_OK


def readable_twice(path: Path) -> None:
    """``fit arm-cmm`` reads a recording more than once (its rows, its hash, its screening): a
    pipe (``<(cat file.csv)``) is empty the second time, which read as missing columns."""
    import stat

    from calibench.scenarios.report import BadInput

    try:
        mode = Path(path).stat().st_mode
    except (OSError, RuntimeError):
        return  # said by the loader, with its reason
    if stat.S_ISFIFO(mode) or stat.S_ISCHR(mode) or stat.S_ISSOCK(mode):
        raise BadInput(
            f"{path}: a pipe or a device, which can be read only once; fit reads a recording "
            "more than once: save it to a file and give the file"
        )


def fit_arm(args: argparse.Namespace, out: Path) -> int:
    """``fit arm-cmm``: the fit, its held-out and test errors; 1 when the solve did not converge."""
    from calibench.scenarios.arm_cmm.fit import run_arm_fit

    for p in [*args.recordings, *(args.test or []), *(args.test_new_frame or [])]:
        readable_twice(p)
    if args.leave_one_out:
        return _leave_one_out(args, out)
    # on one BLAS thread, as each fold of --leave-one-out: the arm's normal equations have a
    # few dozen columns, which a second thread does not speed up, and on a busy machine each
    # product waits for the other thread's core (the UR10's four series, --holdout 0.3, on two
    # shared cores: 115 s wall and 112 s CPU, the threads spinning; on one thread 10 s)
    from threadpoolctl import threadpool_limits

    with threadpool_limits(1):
        r = run_arm_fit(
            args.recordings,
            args.arm,
            args.test,
            args.test_new_frame,
            args.holdout,
            args.model,
            out,
            args.effects,
        )
    f = r["fit"]
    print(
        f"{r['arm']}, model {r['model']}: {r['samples']} training rows, {len(r['parameters'])} "
        "parameters "
        f"({len(r['dropped'])} dropped); fit mean {f['mean_mm']:.3f} mm, rms {f['rms_mm']:.3f} mm, "
        f"max {f['max_mm']:.3f} mm"
    )
    blocks = (
        ("held out", r.get("holdout", {})),
        ("test", r.get("test", {})),
        ("in-sample", r.get("in_sample", {})),
    )
    for title, block in blocks:
        for name, e in block.items():
            print(
                f"  {title} {name}: mean {e['mean_mm']:.3f}  rms {e['rms_mm']:.3f}  p95 "
                f"{e['p95_mm']:.3f}  max {e['max_mm']:.3f} mm  (n = {e['samples']})"
                + (f": {e['why']}" if title == "in-sample" else "")
            )
            for tool, t in e.get("tools", {}).items():  # a branched arm's, tool by tool
                print(
                    f"    tool {tool}: mean {t['mean_mm']:.3f}  rms {t['rms_mm']:.3f}  max "
                    f"{t['max_mm']:.3f} mm  (n = {t['samples']})"
                )
    if r.get("holdout"):
        print(f"  (held out: {next(iter(r['holdout'].values()))['kind']})")
    for name, rows in r.get("flagged", {}).items():
        print(f"  left out of {name}: rows {', '.join(str(x['row']) for x in rows)} (see fit.json)")
    for w in r["coverage"]["warnings"]:
        print(f"  warning: {w}")
    print(f"-> {out / 'fit.json'}")
    if r["implausible"]:
        print(f"calibench: fit arm-cmm failed: {r['implausible']}", file=sys.stderr)
        return EXIT_CHECK_FAILED
    if not r["converged"]:  # a millimetre off and more: a description or a unit, not the solve
        why = f"is --arm {r['arm']} right, the columns in degrees and mm?" * (f["rms_mm"] > 1.0)
        print(
            "calibench: fit arm-cmm did not converge, the figures are of its last iterate "
            f"({f['rms_mm']:.3g} mm RMS){': ' + why if why else ''}",
            file=sys.stderr,
        )
        return EXIT_CHECK_FAILED
    return EXIT_OK


def _leave_one_out(args: argparse.Namespace, out: Path) -> int:
    """``fit arm-cmm --leave-one-out``: every session scored by a calibration on the others."""
    from calibench.scenarios.arm_cmm.sessions import leave_one_session_out
    from calibench.scenarios.report import BadInput

    given = [
        o
        for o, v in (
            ("--test", args.test),
            ("--test-new-frame", args.test_new_frame),
            ("--holdout", args.holdout),
        )
        if v
    ]
    if given:
        raise BadInput(
            f"--leave-one-out scores every recording by the others: {', '.join(given)} "
            "would be another split"
        )
    r = leave_one_session_out(args.recordings, args.arm, args.model, out, args.effects)
    print(f"{r['arm']}, model {r['model']}, each session left out in turn:")
    for name, e in r["leave_one_out"].items():
        print(
            f"  {name}: mean {e['mean_mm']:.3f}  rms {e['rms_mm']:.3f}  p95 {e['p95_mm']:.3f}  "
            f"max {e['max_mm']:.3f} mm  (n = {e['samples']}; {e['frame']})"
            + ("  in-sample" if e["in_sample"] else "")
        )
    print(f"-> {out / 'fit.json'}")
    return EXIT_OK
