"""The ``calibench`` verbs' handlers: each takes the parsed arguments, runs its scenario's code,
prints what the user reads on the console and returns the exit status (bad input is raised as
:class:`~calibench.errors.BadInput`, which ``main`` says in one line)."""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from calibench.scenarios.cli.claims import Claim, claim, release
from calibench.scenarios.cli.status import EXIT_CHECK_FAILED, EXIT_OK, run_verdict
from calibench.scenarios.registry import check_fidelity, check_option, takers


def scenario_named(name: str):
    """A scenario by its name (checked), only its own module imported."""
    from calibench.scenarios.registry import scenario

    _known(name)
    return scenario(name)  # its module alone: the others would cost a second or two of imports


def _known(name: str) -> None:
    """A scenario's name checked, its module not imported (half a second a study's workers need)."""
    from calibench.scenarios.registry import NAMES, PLANNED
    from calibench.scenarios.report import BadInput

    if name in PLANNED:
        raise BadInput(f"scenario {name!r} is not built yet (available: {', '.join(NAMES)})")
    if name not in NAMES:
        raise BadInput(f"unknown scenario {name!r} (available: {', '.join(NAMES)})")


def run(args: argparse.Namespace) -> int:
    """``calibench run``: simulate each scenario asked for, calibrate, compare with the truth and
    write its report.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed arguments of ``calibench run``.

    Returns
    -------
    int
        0 when every check passed, 1 when one failed.
    """
    from calibench.scenarios.config import check_mujoco_gl, check_tables, load_toml, override
    from calibench.scenarios.registry import NAMES
    from calibench.scenarios.report import BadInput

    names = list(NAMES) if args.scenario == "all" else [args.scenario]
    scenarios = [scenario_named(n) for n in names]
    if args.scenario != "all":  # all: rendered where a scenario has a camera
        check_fidelity(args.scenario, args.fidelity)
    fidelity = args.fidelity or "render"
    check_mujoco_gl(renders=fidelity == "render" and any(s.renders for s in scenarios))
    table = load_toml(args.config) if args.config else {}
    check_tables(args.config, table, names, list(NAMES))
    configs = {s.name: override(s.config(), table.get(s.name, {}), s.name) for s in scenarios}
    check_option("--save-images", args.save_images, args.scenario)
    arms = [n for n in configs if n in takers("--arm")]
    if args.arm is not None:
        if not arms:  # run all takes it for the instruments that do
            check_option("--arm", args.arm, args.scenario)
        configs.update({n: override(configs[n], {"arm": args.arm}, n) for n in arms})
    for n in arms:
        from calibench.scenarios.arm_cmm.scenario import check_cones
        from calibench.scenes.arm_cmm import load_arm

        load_arm(configs[n].arm)  # a bad arm is said before anything runs
        check_cones(configs[n])  # and cones it cannot reach
    failed: list[str] = []
    for s in scenarios:
        out = args.out / s.name if args.scenario == "all" else args.out
        held: list[Claim] = []
        try:
            if args.scenario == "all":  # each scenario's folder claimed and released in turn
                claim(out, "run", s.name, args.force, held)
            t0 = time.perf_counter()
            how = f"seed {args.seed}, {fidelity}" if s.renders else f"seed {args.seed}"
            print(f"calibench: {s.name} ({how})", file=sys.stderr, flush=True)
            report = s.execute(configs[s.name], args.seed, fidelity, out, not args.no_rrd)
            report.elapsed_s = time.perf_counter() - t0
            path = report.write(out)
            if args.no_rrd:
                from calibench.scenarios.harness import without_former_recording

                without_former_recording(out)
        except BadInput as e:
            raise BadInput(f"{s.name}: {e}") from None
        finally:
            release(held, reraise=True)
        print(report.table())
        gl = f", rendered by {report.info['renderer']}" if "renderer" in report.info else ""
        verdict = "ok" if report.ok else "FAILED"
        print(f"\n{s.name}: {verdict} in {report.elapsed_s:.1f} s{gl} -> {path}")
        if "recording" in report.info:  # what the sensors recorded, for fit and discover
            print(f"recording -> {path.parent / report.info['recording']}")
        if not report.ok:
            failed.append(s.name)
    if args.save_images is not None:
        from calibench.scenarios.belt_stage.images import save_rendered_views
        from calibench.writing import write_text

        # the folder known as the views' from their start (a save cut off is resumed by the next),
        # and no former truth.json left to vouch for views half replaced
        stub = {"camera": None, "board": None, "seed": args.seed, "corners_px": {}}
        write_text(args.save_images / "truth.json", json.dumps({**stub, "note": "being written"}))
        truth = save_rendered_views(configs[args.scenario], args.seed, args.save_images)
        print(
            f"-> {args.save_images}: {len(truth['corners_px'])} rendered views and truth.json "
            f"(calibench camera {args.save_images}/view*.png --cols {truth['board']['cols']} "
            f"--rows {truth['board']['rows']} --square-mm {truth['board']['square_mm']:g})"
        )
    return run_verdict(failed, len(scenarios), args.scenario == "all")


def fit(args: argparse.Namespace) -> int:
    """``calibench fit``: fit the scenario's error model to real recordings (arm-cmm: the
    arm's parameters, tested on held-out rows and recordings).

    Parameters
    ----------
    args : argparse.Namespace
        The parsed arguments of ``calibench fit``.

    Returns
    -------
    int
        0 when the fit is done, 1 when the arm's solve did not converge or its fit is far
        beyond any arm's error (a wrong description, wrong units).
    """
    from calibench.scenarios.registry import FIT_MODELS
    from calibench.scenarios.report import BadInput

    s = scenario_named(args.scenario)
    out = args.out
    if s.fit_model == "arm":
        from calibench.scenarios.cli.fit_arm import fit_arm

        return fit_arm(args, out)
    arm_only = [
        o
        for o, v in (
            ("--arm", args.arm),
            ("--test", args.test),
            ("--test-new-frame", args.test_new_frame),
            ("--holdout", args.holdout),
            ("--model", args.model),
            ("--effects", args.effects),
            ("--leave-one-out", args.leave_one_out),
        )
        if v
    ]
    if arm_only:
        verb = "applies" if len(arm_only) == 1 else "apply"
        arm_fits = ", ".join(n for n, m in FIT_MODELS.items() if m == "arm")
        raise BadInput(f"fit {s.name}: {', '.join(arm_only)} {verb} to {arm_fits} only")
    if s.fit_model is None:
        raise BadInput(f"fit: scenario {s.name!r} has no fit model")
    if len(args.recordings) != 1:
        raise BadInput(f"fit {s.name}: one recording, not {len(args.recordings)}")
    from calibench.scenarios.stage_fit import run_fit

    result = run_fit(s.name, s.fit_model, args.recordings[0], out)
    for axis, a in result["axes"].items():
        # no R^2 where the errors are all alike: nothing for the map to explain
        r2 = "n/a" if a["r2"] is None else f"{a['r2']:.4f}"
        print(f"{axis}: SSE {a['sse']:.4g} mm^2  R^2 {r2}  RMSE {a['rmse']:.4f} mm  (n = {a['n']})")
    print(f"-> {out / 'fit.json'}")
    return EXIT_OK


def montecarlo(args: argparse.Namespace) -> int:
    """``calibench montecarlo``: run (or resume) a study and print its coverage and checks
    tables.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed arguments of ``calibench montecarlo``.

    Returns
    -------
    int
        0 when every trial ran, 1 when some failed.
    """
    from calibench.scenarios.study.montecarlo import run_study
    from calibench.scenarios.study.summary import checks_table, summary_table

    _known(args.scenario)
    check_fidelity(args.scenario, args.fidelity)
    tls = {"ca_file": args.tls_ca_file, "cert": args.tls_cert, "key": args.tls_key}
    if args.scheduler is None and any(tls.values()):
        from calibench.scenarios.report import BadInput

        raise BadInput("--tls-* files are for a Dask cluster's --scheduler tls://...; none given")
    out = args.out
    arm = None
    if args.arm is not None:
        from calibench.scenarios.report import BadInput
        from calibench.scenes.arm_cmm import BUILTIN, load_arm

        check_option("--arm", args.arm, args.scenario)
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
                f"config {args.config}: a study of {args.scenario} takes only its "
                f"[{args.scenario}] table (found {', '.join(other)})"
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
        tls=tls,
    )
    print(
        f"{s['scenario']}: {s['trials']} trials ({s['resumed']} kept from an earlier run, "
        f"{s['failed']} failed); this run took {s['elapsed_s']:.1f} s"
    )
    print(summary_table(s))
    if checks_table(s):
        print("\n" + checks_table(s))
    print(f"-> {out / 'summary.json'}")
    if s["failed"]:
        print(
            f"calibench: {s['failed']} of {s['trials']} trials failed, e.g. {s['errors'][0]} "
            f"(every error and its trials: {out / 'trials.parquet'})",
            file=sys.stderr,
        )
    return EXIT_OK if s["failed"] == 0 else EXIT_CHECK_FAILED


def discover(args: argparse.Namespace) -> int:
    """``calibench discover``: where a recording disagrees with the twin, and the effects found.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed arguments of ``calibench discover``.

    Returns
    -------
    int
        0 when the discovery ran.
    """
    from calibench.scenarios.discover.confirm import status_words
    from calibench.scenarios.discover.engine import run_discover

    out = args.out
    check_option("--arm", args.arm, args.scenario)
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
        f"{d['scenario']}: {d['samples']} samples; held-out RMS {f['cv_rms_nominal'] * 1000:.2f} "
        "um with the "
        f"scene model, {f['cv_rms_final'] * 1000:.2f} um with what was found ({d['holdout']})"
    )
    for loc in d.get("located", []):
        print(
            f"- located: {loc['signal']} follows {loc['driver']}, {loc['where']} (score "
            f"{loc['score']:.2f}, p {loc['p_value']:.3f})"
        )
    for e in d["effects"]:
        carry = ""
        if "belongs" in e:
            s = e["new_session_rms"]
            refit = f"{e['new_session']}; " if "new_session" in e else ""
            carry = (
                f"; belongs to the {e['belongs']} ({refit}sessions held out whole: "
                f"{s['without'] * 1000:.0f} -> {s['with'] * 1000:.0f} um)"
            )
        said = status_words(e, d.get("holdout_schemes", []))
        print(
            f"- {e['name']} ({e['axis']}): {e['physics']}; held-out RMS "
            f"{e['cv_rms_before'] * 1000:.2f} -> {e['cv_rms_after'] * 1000:.2f} um{carry}"
            + (f"; {said}" if said else "")
        )
    for c in d["confounded"]:
        print(
            f"- cannot separate {c['effect']} ({c['axis']}): {c['why']}; to separate: "
            f"{c['experiment']}"
        )
    if d.get("verdict"):
        print(d["verdict"])
    elif not d["effects"]:
        print("- nothing missing: the scene model explains the recording")
    if d.get("summary"):
        print(d["summary"])
    if args.twin is not None:
        from calibench.scenarios.discover.twin_merge import twin_said

        print(twin_said(d, args.twin, args.scenario))
    print(f"-> {out / 'discovery.json'}")
    return EXIT_OK


def scenario_names() -> list[str]:
    """Every instrument's name, in the registry's order (a config's tables are checked
    against them)."""
    from calibench.scenarios.registry import NAMES

    return list(NAMES)


def camera(args: argparse.Namespace) -> int:
    """``calibench camera``: a camera's intrinsics from chessboard photos.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed arguments of ``calibench camera``.

    Returns
    -------
    int
        0 when the calibration ran.
    """
    from calibench.scenarios.camera import run_camera
    from calibench.scenarios.camera_figure import COVERAGE_GRID, COVERAGE_WARN

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
    print("distortion: " + "  ".join(f"{k} {v:+.5g}" for k, v in r["distortion"].items()))
    cover = r["corner_coverage"]
    print(
        f"the corners cover {cover:.0%} of the image (cells of an {COVERAGE_GRID} x "
        f"{COVERAGE_GRID} grid)"
        + (
            ": the distortion is extrapolated where the board never went; add photos with "
            "the board near the image's edges and corners"
            if cover < COVERAGE_WARN
            else ""
        )
    )
    for photo, corners in r["corners_left_out"].items():
        print(
            f"  {photo}: left out corner(s) "
            + ", ".join(f"{c['corner']} ({c['off_grid_px']} px off the grid)" for c in corners)
        )
    print(f"-> {args.out / 'intrinsics.json'}, {args.out / 'camera.png'}")
    return EXIT_OK
