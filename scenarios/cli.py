"""The ``calibench`` command line (CONTRACT.md). Bad input: one line on stderr, exit status 2."""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

EXIT_OK, EXIT_CHECK_FAILED, EXIT_BAD_INPUT, EXIT_INTERNAL = 0, 1, 2, 3
MAX_TRIALS = 1_000_000


class _Parser(argparse.ArgumentParser):
    """argparse that reports a usage error in one line (it prints usage plus a line by default)."""

    def error(self, message: str):
        self.exit(EXIT_BAD_INPUT, f"{self.prog}: {message} (see {self.prog} --help)\n")


def _ranged(kind: type, ok, rule: str):
    """An argparse type: the text as ``kind`` (int or float), refused in one line unless
    ``ok(value)``; ``rule`` says the range in words."""
    noun = "a whole number" if kind is int else "a number"

    def parse(text: str):
        try:
            v = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not {noun}") from None
        if not ok(v):
            raise argparse.ArgumentTypeError(f"{text}: {rule}")
        return v

    return parse


# more local processes than a few per core only compete (and each holds a scenario in memory)
MAX_WORKERS = 4 * (os.cpu_count() or 1)
_workers = _ranged(
    int,
    lambda v: 1 <= v <= MAX_WORKERS,
    f"from 1 to {MAX_WORKERS} local workers on this machine ({os.cpu_count()} cores)",
)
_seed = _ranged(int, lambda v: 0 <= v < 2**63, "a seed is a whole number from 0 to 2^63 - 1")
_trials = _ranged(
    int,
    lambda v: 1 <= v <= MAX_TRIALS,
    f"from 1 to {MAX_TRIALS} trials a study (run several studies)",
)
_fraction = _ranged(float, lambda v: 0 < v < 0.9, "a fraction between 0 and 0.9")
_square_mm = _ranged(
    float, lambda v: 0.001 <= v <= 10_000, "a square's side from 0.001 to 10000 mm"
)
_board_count = _ranged(int, lambda v: v >= 2, "a board has at least 2 inner corners each way")


def _parser() -> argparse.ArgumentParser:
    from calibench.scenarios.registry import FIT_MODELS, NAMES, PLANNED

    names = ", ".join(NAMES)
    p = _Parser(
        prog="calibench",
        description="Simulation-first test bench for calibrating measuring machines.",
    )
    from calibench import __version__

    p.add_argument("--version", action="version", version=f"calibench {__version__}")
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser)

    r = sub.add_parser(
        "run",
        help="simulate a scenario, calibrate, compare with the truth",
        description=f"Run a scenario ({names}) or all of them; writes DIR/report.json and DIR/run.rrd.",
    )
    r.add_argument("scenario", help=f"one of: {names}; or 'all'")
    r.add_argument("--seed", type=_seed, default=0, help="random seed (default 0)")
    r.add_argument("--out", type=_folder, help="output folder (default ./calibench-out/<scenario>)")
    r.add_argument(
        "--fidelity",
        choices=("render", "analytic"),
        default="render",
        help="render: pixels through MuJoCo's renderer and the real detector; "
        "analytic: exact projection plus detector noise (default render)",
    )
    r.add_argument(
        "--config", type=Path, help="TOML file with one table per scenario overriding its defaults"
    )
    r.add_argument("--no-rrd", action="store_true", help="do not write the rerun recording")
    r.add_argument(
        "--arm",
        help="arm-cmm: ARM.toml or a built-in arm (arm-cmm, ur10) instead of the seed's arm",
    )

    fit_names = ", ".join(list(FIT_MODELS) + ["arm-cmm"])
    f = sub.add_parser(
        "fit",
        help="fit the scenario's error model to real recordings (CSV)",
        description="Fit the scenario's calibration model to recordings; writes DIR/fit.json. "
        "Stages: one recording (x_cmd_mm, y_cmd_mm, x_meas_mm, y_meas_mm). arm-cmm: "
        "one or more training recordings (q1_deg.., x_mm, y_mm, z_mm), each with its "
        "own base frame, and recordings to test the result on.",
    )
    f.add_argument("scenario", help=f"one of: {fit_names}")
    f.add_argument("recordings", type=Path, nargs="+", metavar="RECORDING", help="CSV recording(s)")
    f.add_argument("--out", type=_folder, help="output folder (default ./calibench-out/<scenario>)")
    f.add_argument(
        "--arm", help="arm-cmm: ARM.toml or a built-in arm (arm-cmm, ur10); default the seed's arm"
    )
    f.add_argument(
        "--test",
        type=Path,
        action="append",
        default=[],
        metavar="CSV",
        help="arm-cmm: a recording in the first training recording's frame to test on (repeatable)",
    )
    f.add_argument(
        "--test-new-frame",
        type=Path,
        action="append",
        default=[],
        metavar="CSV",
        help="arm-cmm: a recording from another setup: registered on 20 %% of its rows, tested on "
        "the rest (repeatable)",
    )
    f.add_argument(
        "--holdout",
        type=_fraction,
        metavar="F",
        help="arm-cmm: keep a fraction F of every training recording out of the fit (fixed seed)",
    )
    f.add_argument(
        "--model",
        choices=("geometry", "physics"),
        help="arm-cmm: geometry (kinematics, base, tool) or physics (and the joints' compliance "
        "under gravity); default physics when the arm has masses",
    )
    f.add_argument(
        "--effects",
        metavar="DISCOVERY.json|discover",
        help="arm-cmm: add the joint-angle effects a discover run found (transmission, eccentricity, "
        "a nonsmooth table) to the model; 'discover' runs the discovery here on the training rows",
    )

    mc = sub.add_parser(
        "montecarlo",
        help="an accuracy study: many trials, truth drawn from the prior",
        description="Run N trials of a scenario (truth from its prior, noise from its sensors); "
        "writes DIR/trials.parquet, DIR/summary.json, DIR/study.png. "
        "Rerunning the same command resumes: finished trials are kept.",
    )
    mc.add_argument("scenario", help=f"one of: {names}")
    mc.add_argument("--trials", type=_trials, required=True, help="number of trials")
    mc.add_argument("--workers", type=_workers, help="local worker processes (default: all cores)")
    mc.add_argument(
        "--scheduler", help="address of a Dask scheduler (tcp://host:8786) instead of local workers"
    )
    mc.add_argument("--seed", type=_seed, default=0, help="study seed (default 0)")
    mc.add_argument(
        "--out", type=_folder, help="output folder (default ./calibench-out/<scenario>-montecarlo)"
    )
    mc.add_argument(
        "--fidelity",
        choices=("render", "analytic"),
        default="analytic",
        help="sensor fidelity of each trial (default analytic)",
    )
    mc.add_argument("--arm", help="arm-cmm: ARM.toml or a built-in arm (arm-cmm, ur10)")
    mc.add_argument(
        "--config",
        type=Path,
        help="TOML overriding the scenario's defaults, as for run (its "
        "[scenario] table); the prior then draws around them",
    )

    d = sub.add_parser(
        "discover",
        help="where a recording disagrees with the twin, and which physics is missing",
        description="Compare a recording with the twin replaying its commands; locate the "
        "mismatch, name and fit the missing effects, show the held-out fit improve. "
        "Writes DIR/discovery.json and DIR/discovery.png.",
    )
    d.add_argument(
        "scenario", help="one of: belt-stage, vision-stage, probe-scanner, arm-cmm, stewart"
    )
    d.add_argument(
        "recording",
        type=Path,
        nargs="+",
        help="CSV in the CONTRACT's format for the scenario (arm-cmm: "
        "one or more, each with its own base frame)",
    )
    d.add_argument(
        "--out", type=_folder, help="output folder (default ./calibench-out/<scenario>-discover)"
    )
    d.add_argument(
        "--seed", type=_seed, default=0, help="seed of the permutation tests (default 0)"
    )
    d.add_argument(
        "--arm", help="arm-cmm: ARM.toml or a built-in arm (arm-cmm, ur10); default the seed's arm"
    )
    d.add_argument(
        "--config",
        type=Path,
        help="a run --config file whose twin replays the recording (e.g. one --twin wrote)",
    )
    d.add_argument(
        "--twin",
        type=Path,
        help="write the twin updated with what was found, as a run --config file",
    )
    d.add_argument(
        "--holdout",
        choices=("pass", "rows", "columns", "blocks"),
        help="what cross-validation holds out (default: passes if the recording has several, "
        "else whole rows of a grid, else contiguous blocks)",
    )

    c = sub.add_parser(
        "camera",
        help="calibrate a camera from chessboard photos",
        description="Calibrate a camera from real chessboard photos; writes DIR/intrinsics.json.",
    )
    c.add_argument("images", nargs="+", type=Path, help="photos of the chessboard")
    c.add_argument("--cols", type=_board_count, required=True, help="inner corners per row")
    c.add_argument("--rows", type=_board_count, required=True, help="inner corners per column")
    c.add_argument("--square-mm", type=_square_mm, required=True, help="side of a square, mm")
    c.add_argument("--fix-aspect", action="store_true", help="keep fx = fy")
    c.add_argument(
        "--radial", type=int, choices=(2, 3), default=3, help="radial terms k1..k3 (default 3)"
    )
    c.add_argument("--no-tangential", action="store_true", help="no tangential terms p1, p2")
    c.add_argument(
        "--out", type=_folder, default=Path("calibench-out/camera"), help="output folder"
    )
    i = sub.add_parser(
        "iso230",
        help="ISO 230-2 evaluation of a real bidirectional run of one axis",
        description="Evaluate a bidirectional positioning run (target_mm, run, direction, and "
        "deviation_um or actual_mm) as ISO 230-2:2014; writes DIR/iso230.json and "
        "DIR/iso230.png.",
    )
    i.add_argument("run", type=Path, metavar="RUN.csv", help="the run, one row per reading")
    i.add_argument(
        "--out", type=_folder, default=Path("calibench-out/iso230"), help="output folder"
    )
    if PLANNED:
        p.epilog = f"Scenarios planned but not built yet: {', '.join(PLANNED)}."
    return p


def main(argv: list[str] | None = None) -> int:
    """The ``calibench`` command; returns its exit status (CONTRACT: 0 ok, 1 a check failed,
    2 bad input in one line, 3 an internal error with the traceback in OUT/error.log, 130
    interrupted). ``argv``: the arguments (default ``sys.argv[1:]``)."""
    import os

    os.environ.setdefault(
        "MUJOCO_GL", "egl"
    )  # before MuJoCo's first import: renders without a display
    try:
        args = _parser().parse_args(argv)
    except SystemExit as e:  # usage errors (status 2) and --help (0), as a return value
        return e.code if isinstance(e.code, int) else EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print("calibench: interrupted", file=sys.stderr)
        return 130
    created = None
    try:
        created = _check_out(getattr(args, "out", None))
        return {
            "run": _run,
            "fit": _fit,
            "camera": _camera,
            "montecarlo": _montecarlo,
            "discover": _discover,
            "iso230": _iso230,
        }[args.command](args)
    except BrokenPipeError:  # the reader went away (| head): nothing to say
        sys.stderr.close()
        return EXIT_OK
    except KeyboardInterrupt:
        kept = (
            "; finished trials are kept, rerun the same command to resume"
            if args.command == "montecarlo"
            else ""
        )
        print(f"calibench: interrupted{kept}", file=sys.stderr)
        return 130
    except Exception as e:  # noqa: BLE001 - bad input is reported in one line
        from calibench.errors import BadInput

        if isinstance(e, BadInput):
            print(f"calibench: {e}", file=sys.stderr)
            if created is not None and created.is_dir() and not any(created.iterdir()):
                created.rmdir()
            return EXIT_BAD_INPUT
        return _internal_error(e, getattr(args, "out", None))


def _folder(text: str) -> Path:
    """--out's folder; an empty one is refused (it would be the current folder, silently)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("is empty: give an output folder")
    return Path(text)


def _check_out(out: Path | None) -> Path | None:
    """--out must be a folder calibench can write: said before any work. Returns the folder if
    this call created it (removed again if the command ends in bad input, empty)."""
    if out is None:
        return None
    from calibench.scenarios.report import BadInput

    out = Path(out)
    try:
        for parent in [out, *out.parents]:
            if parent.exists() and not parent.is_dir():
                raise BadInput(f"--out {out}: {parent} is a file, not a folder")
        created = None if out.exists() else out
    except OSError as e:  # a name too long for the file system, a folder that cannot be read
        raise BadInput(
            f"--out {str(out)[:80]}{'...' if len(str(out)) > 80 else ''}: cannot write there "
            f"({e.strerror})"
        ) from None
    try:
        out.mkdir(parents=True, exist_ok=True)
        probe = out / ".calibench-write-test"
        probe.touch()
        probe.unlink()
    except OSError as e:
        raise BadInput(f"--out {out}: cannot write there ({e.strerror})") from None
    return created


def _internal_error(e: Exception, out: Path | None) -> int:
    """A defect of calibench: one line, the traceback in OUT/error.log (CONTRACT's exit 3)."""
    import traceback

    try:
        where = Path(out) if out is not None and not Path(out).is_file() else Path("calibench-out")
    except OSError:
        where = Path("calibench-out")
    text = "".join(traceback.format_exception(e))
    try:
        where.mkdir(parents=True, exist_ok=True)
        (where / "error.log").write_text(text)
        said = f"the traceback is in {where / 'error.log'}"
    except OSError:
        said = "the traceback could not be written"
    print(
        f"calibench: internal error ({type(e).__name__}: {str(e).splitlines()[0] if str(e) else ''}); this is a "
        f"defect of calibench, please report it; {said}",
        file=sys.stderr,
    )
    return EXIT_INTERNAL


def _scenario(name: str):
    from calibench.scenarios.registry import scenario

    _known(name)
    return scenario(name)  # its module alone: the others would cost a second or two of imports


def _known(name: str) -> None:
    """A scenario's name checked, its module not imported (half a second a study's workers need)."""
    from calibench.scenarios.registry import NAMES, PLANNED
    from calibench.scenarios.report import BadInput

    if name in NAMES:
        return
    if name in PLANNED:
        raise BadInput(f"scenario {name!r} is not built yet (available: {', '.join(NAMES)})")
    raise BadInput(f"unknown scenario {name!r} (available: {', '.join(NAMES)})")


def _run(args) -> int:
    from calibench.scenarios.config import load_toml, override
    from calibench.scenarios.registry import NAMES
    from calibench.scenarios.report import BadInput

    names = list(NAMES) if args.scenario == "all" else [args.scenario]
    scenarios = [_scenario(n) for n in names]
    table = load_toml(args.config) if args.config else {}
    unknown = [k for k in table if k not in NAMES]
    if unknown:
        raise BadInput(f"config {args.config}: unknown scenario table(s) {', '.join(unknown)}")
    configs = {s.name: override(s.config(), table.get(s.name, {}), s.name) for s in scenarios}
    if args.arm is not None:
        if "arm-cmm" not in configs:
            raise BadInput(f"--arm applies to arm-cmm, not {args.scenario}")
        configs["arm-cmm"] = override(configs["arm-cmm"], {"arm": args.arm}, "arm-cmm")
    if "arm-cmm" in configs:
        from calibench.scenarios.arm_cmm.scenario import check_cones
        from calibench.scenes.arm_cmm import load_arm

        load_arm(configs["arm-cmm"].arm)  # a bad arm is said before anything runs
        check_cones(configs["arm-cmm"])  # and cones it cannot reach
    status = EXIT_OK
    for s in scenarios:
        if args.out is None:
            out = Path("calibench-out") / s.name
        else:
            out = args.out / s.name if args.scenario == "all" else args.out
        t0 = time.perf_counter()
        how = f"seed {args.seed}, {args.fidelity}" if s.renders else f"seed {args.seed}"
        print(f"calibench: {s.name} ({how})", file=sys.stderr, flush=True)
        try:
            report = s.execute(configs[s.name], args.seed, args.fidelity, out, not args.no_rrd)
        except BadInput as e:
            raise BadInput(f"{s.name}: {e}") from None
        report.elapsed_s = time.perf_counter() - t0
        path = report.write(out)
        print(report.table())
        print(
            f"\n{s.name}: {'ok' if report.ok else 'FAILED'} in {report.elapsed_s:.1f} s -> {path}"
        )
        if not report.ok:
            status = EXIT_CHECK_FAILED
    return status


def _fit(args) -> int:
    from calibench.scenarios.report import BadInput

    s = _scenario(args.scenario)
    out = args.out or Path("calibench-out") / s.name
    if s.name == "arm-cmm":
        return _fit_arm(args, out)
    arm_only = [
        o
        for o, v in (
            ("--arm", args.arm),
            ("--test", args.test),
            ("--test-new-frame", args.test_new_frame),
            ("--holdout", args.holdout),
            ("--model", args.model),
            ("--effects", args.effects),
        )
        if v
    ]
    if arm_only:
        raise BadInput(f"fit {s.name}: {', '.join(arm_only)} apply to arm-cmm only")
    if s.fit_model is None:
        raise BadInput(f"fit: scenario {s.name!r} has no fit model")
    if len(args.recordings) != 1:
        raise BadInput(f"fit {s.name}: one recording, not {len(args.recordings)}")
    from calibench.scenarios.stage_fit import run_fit

    result = run_fit(s.name, s.fit_model, args.recordings[0], out)
    for axis, a in result["axes"].items():
        print(
            f"{axis}: SSE {a['sse']:.4g} mm^2  R^2 {a['r2']:.4f}  RMSE {a['rmse']:.4f} mm  (n = {a['n']})"
        )
    print(f"-> {out / 'fit.json'}")
    return EXIT_OK


def _fit_arm(args, out: Path) -> int:
    from calibench.scenarios.arm_cmm.fit import run_arm_fit

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
        f"{r['arm']}, model {r['model']}: {r['samples']} training rows, {len(r['parameters'])} parameters "
        f"({len(r['dropped'])} dropped); fit mean {f['mean_mm']:.3f} mm, rms {f['rms_mm']:.3f} mm, "
        f"max {f['max_mm']:.3f} mm"
    )
    for title, block in (("held out", r.get("holdout", {})), ("test", r.get("test", {}))):
        for name, e in block.items():
            print(
                f"  {title} {name}: mean {e['mean_mm']:.3f}  rms {e['rms_mm']:.3f}  p95 {e['p95_mm']:.3f}  "
                f"max {e['max_mm']:.3f} mm  (n = {e['samples']})"
            )
    for name, rows in r.get("flagged", {}).items():
        print(f"  left out of {name}: rows {', '.join(str(x['row']) for x in rows)} (see fit.json)")
    for w in r["coverage"]["warnings"]:
        print(f"  warning: {w}")
    if not r["converged"]:
        print("  the solve did not converge: the figures are of its last iterate", file=sys.stderr)
    print(f"-> {out / 'fit.json'}")
    return EXIT_OK if r["converged"] else EXIT_CHECK_FAILED


def _montecarlo(args) -> int:
    from calibench.scenarios.study.montecarlo import checks_table, run_study, summary_table

    _known(args.scenario)
    out = args.out or Path("calibench-out") / f"{args.scenario}-montecarlo"
    arm = None
    if args.arm is not None:
        from calibench.scenarios.report import BadInput
        from calibench.scenes.arm_cmm import BUILTIN, load_arm

        if args.scenario != "arm-cmm":
            raise BadInput(f"--arm applies to arm-cmm, not {args.scenario}")
        load_arm(args.arm)  # a bad file is said here, not in every trial
        arm = args.arm if args.arm in BUILTIN else str(Path(args.arm).resolve())
    table = None
    if args.config is not None:
        from calibench.scenarios.config import load_toml
        from calibench.scenarios.report import BadInput

        doc = load_toml(args.config)
        other = [k for k in doc if k != args.scenario]
        if other:
            raise BadInput(
                f"config {args.config}: a study of {args.scenario} takes only its [{args.scenario}] table "
                f"(found {', '.join(other)})"
            )
        table = doc.get(args.scenario, {})
    s = run_study(
        args.scenario,
        args.trials,
        args.seed,
        args.fidelity,
        out,
        args.workers,
        args.scheduler,
        arm=arm,
        table=table,
    )
    print(
        f"{s['scenario']}: {s['trials']} trials ({s['resumed']} kept from an earlier run, {s['failed']} failed); "
        f"this run took {s['elapsed_s']:.1f} s"
    )
    print(summary_table(s))
    if checks_table(s):
        print("\n" + checks_table(s))
    print(f"-> {out / 'summary.json'}")
    if s["failed"]:
        print(
            f"calibench: {s['failed']} of {s['trials']} trials failed, e.g. {s['errors'][0]} (every error and its "
            f"trials: {out / 'trials.parquet'})",
            file=sys.stderr,
        )
    return EXIT_OK if s["failed"] == 0 else EXIT_CHECK_FAILED


def _discover(args) -> int:
    from calibench.scenarios.discover.engine import run_discover

    out = args.out or Path("calibench-out") / f"{args.scenario}-discover"
    if args.arm is not None and args.scenario != "arm-cmm":
        from calibench.scenarios.report import BadInput

        raise BadInput(f"--arm applies to arm-cmm, not {args.scenario}")
    d = run_discover(
        args.scenario,
        args.recording,
        out,
        args.seed,
        args.holdout,
        args.arm,
        args.config,
        args.twin,
    )
    f = d["fit"]
    print(
        f"{d['scenario']}: {d['samples']} samples; held-out RMS {f['cv_rms_nominal'] * 1000:.2f} um with the "
        f"scene model, {f['cv_rms_final'] * 1000:.2f} um with what was found ({d['holdout']})"
    )
    for e in d["effects"]:
        print(
            f"- {e['name']} ({e['axis']}): {e['physics']}; held-out RMS {e['cv_rms_before'] * 1000:.2f} -> "
            f"{e['cv_rms_after'] * 1000:.2f} um"
        )
    for c in d["confounded"]:
        print(
            f"- cannot separate {c['effect']} ({c['axis']}): {c['why']}; to separate: {c['experiment']}"
        )
    if d.get("verdict"):
        print(d["verdict"])
    elif not d["effects"]:
        print("- nothing missing: the scene model explains the recording")
    if d.get("summary"):
        print(d["summary"])
    if args.twin is not None:
        print(
            f"-> {args.twin} (the twin with what was found: calibench discover {args.scenario} ... --config "
            f"{args.twin} replays it)"
        )
    print(f"-> {out / 'discovery.json'}")
    return EXIT_OK


def _iso230(args) -> int:
    from calibench.scenarios.iso230 import run_iso230

    r = run_iso230(args.run, args.out)
    a = r["axis"]
    print(
        f"ISO 230-2, {r['targets']} targets, {r['runs']} runs each way (um): A {a['A']:.3f}  E {a['E']:.3f}  "
        f"M {a['M']:.3f}  R {a['R']:.3f}  B {a['B']:.3f}  (A up {a['A_up']:.3f}, down {a['A_down']:.3f})"
    )
    print(f"-> {args.out / 'iso230.json'}")
    return EXIT_OK


def _camera(args) -> int:
    from calibench.scenarios.camera import run_camera

    r = run_camera(
        args.images,
        args.cols,
        args.rows,
        args.square_mm,
        args.fix_aspect,
        args.radial,
        not args.no_tangential,
        args.out,
    )
    K = r["K"]
    print(
        f"fx {K[0][0]:.3f}  fy {K[1][1]:.3f}  cx {K[0][2]:.3f}  cy {K[1][2]:.3f}  "
        f"rms {r['rms_px']:.3f} px  ({len(r['used'])} used, {len(r['rejected'])} rejected)"
    )
    for photo, corners in r["corners_left_out"].items():
        print(
            f"  {photo}: left out corner(s) "
            + ", ".join(f"{c['corner']} ({c['off_grid_px']} px off the grid)" for c in corners)
        )
    print(f"-> {args.out / 'intrinsics.json'}")
    return EXIT_OK


if __name__ == "__main__":
    sys.exit(main())
