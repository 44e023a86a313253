"""The verbs that state a standard's figures: ``iso230`` (ISO 230-2 of a real axis's runs),
``acceptance`` (a standard's acceptance test on a twin) and ``uncertainty`` (JCGM 101's
task-specific uncertainty); each takes the parsed arguments, prints what the user reads and
returns the exit status, as :mod:`.verbs`' handlers do."""

from __future__ import annotations

import argparse
import sys

from calibench.scenarios.cli.status import EXIT_CHECK_FAILED, EXIT_OK
from calibench.scenarios.cli.verbs import scenario_named, scenario_names


def iso230(args: argparse.Namespace) -> int:
    """``calibench iso230``: the ISO 230-2 evaluation of a bidirectional run of one axis.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed arguments of ``calibench iso230``.

    Returns
    -------
    int
        0 when the evaluation ran.
    """
    from calibench.scenarios.iso230 import run_iso230

    r = run_iso230(args.run, args.out)
    a = r["axis"]
    print(
        f"ISO 230-2, {r['targets']} targets, {r['runs']} runs each way (um): A {a['A']:.3f}  E "
        f"{a['E']:.3f}  M {a['M']:.3f}  R {a['R']:.3f}  B {a['B']:.3f}  (A up {a['A_up']:.3f}, "
        f"down {a['A_down']:.3f})"
    )
    if not r["conforms"]:
        print(f"not conforming: {r['reason']}; the figures are evaluated its way on fewer readings")
    print(f"-> {args.out / 'iso230.json'}")
    return EXIT_OK


def acceptance(args: argparse.Namespace) -> int:
    """``calibench acceptance``: a standard's acceptance test on an instrument's twin, before and
    after its calibration.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed arguments of ``calibench acceptance``.

    Returns
    -------
    int
        0 when the test ran and every stated MPE holds after calibration, 1 when one does not.
    """
    from calibench.scenarios.acceptance import (
        procedure,
        real_repeatability,
        run_acceptance,
        stated_mpe,
    )
    from calibench.scenarios.config import check_tables, load_toml, override

    s = scenario_named(args.scenario)
    procedure(s.name, args.test)  # a test that does not apply is said before any work
    table = load_toml(args.config) if args.config else {}
    check_tables(args.config, table, [s.name, "acceptance"], [*scenario_names(), "acceptance"])
    config = override(s.config(), table.get(s.name, {}), s.name)
    stated_mpe(args.test, table)
    real = real_repeatability(s.name, args.test, config, args.recording)  # said before any work
    print(f"calibench: {s.name} {args.test} (seed {args.seed})", file=sys.stderr, flush=True)
    r = run_acceptance(s.name, args.test, config, table, args.seed, args.out, real)
    before, after = r["before"], r["after"]
    for name in (k for k, v in after.items() if isinstance(v, float)):
        print(f"  {name}: {before[name]:.4g} before calibration, {after[name]:.4g} after")
    for real in r.get("recordings", []):
        print(
            f"  {real['recording']}: RP {real['RP_mm']:.3g} +- {real['u_RP_mm']:.2g} mm at 30 "
            f"cycles, from {real['groups']} repeated postures ({len(real['left_out'])} left out)"
        )
    failed = [k for k, v in r.get("mpe", {}).items() if not v["conforms"]]
    for k, v in r.get("mpe", {}).items():
        print(f"  {k} MPE {v['mpe']:g}: {'conforms' if v['conforms'] else 'does not conform'}")
    print(f"-> {args.out / 'acceptance.json'}")
    return EXIT_CHECK_FAILED if failed else EXIT_OK


def uncertainty(args: argparse.Namespace) -> int:
    """``calibench uncertainty``: the task-specific uncertainty of a calibrated instrument over
    its workspace (adaptive Monte Carlo, JCGM 101), beside the GUM framework's.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed arguments of ``calibench uncertainty``.

    Returns
    -------
    int
        0 when the study ran (whether its tolerance was met is said, and in uncertainty.json).
    """
    from calibench.scenarios.config import check_tables, load_toml, override
    from calibench.scenarios.report import BadInput
    from calibench.scenarios.uncertainty import BATCH, run_uncertainty, task_of

    s = scenario_named(args.scenario)
    task_of(s.name)  # a scenario without a task is said before any work
    if args.trials_max < 2 * BATCH:  # the adaptive stop compares batches: two at least
        raise BadInput(f"--trials-max {args.trials_max}: at least {2 * BATCH} (two batches)")
    table = load_toml(args.config) if args.config else {}
    check_tables(args.config, table, [s.name], scenario_names())
    config = override(s.config(), table.get(s.name, {}), s.name)
    # no heading on stderr: a study's progress names itself, and an interrupt's line is its one
    options = {
        "tolerance": args.tolerance,
        "trials_max": args.trials_max,
        "workers": args.workers,
        "scheduler": args.scheduler,
    }
    r = run_uncertainty(s.name, config, args.seed, args.out, options)
    u = [g["u"] for g in r["grid"]]
    v = r["gum_validation"]
    print(
        f"{r['task']}: u {min(u):.3g} to {max(u):.3g} {r['unit']} over {len(u)} quantities, "
        f"{r['trials']} trials, stopped: {r['status']}"
    )
    print(
        f"GUM framework validated at {v['valid_points']} of {len(u)} quantities (worst d_low "
        f"{v['worst_d_low']:.3g}, d_high {v['worst_d_high']:.3g} against delta "
        f"{v['delta']:.3g} {r['unit']}: {'validated' if v['valid'] else 'state the Monte Carlo'}"
        f"); fresh machines inside their 95 % intervals: "
        f"{r['coverage_check']['fraction_inside_95']:.3f}"
    )
    print(f"-> {args.out / 'uncertainty.json'}")
    return EXIT_OK
