"""The ``calibench`` command's argument parser (docs/formats.md, "Command line"): its verbs, their
options, and the ranges a value is checked against before any work (a usage error is one line,
exit status 2)."""

from __future__ import annotations

import argparse
import math
import os
from pathlib import Path

from calibench.scenarios.cli.status import EXIT_BAD_INPUT, one_line

# uncertainty's default bound, above what each instrument's default tolerance asks (the belt
# stage some 10,500 trials of 0.12 s CPU, the platform some 13,000 of 0.07 s): a study stops at
# its tolerance, this only bounds one that cannot reach it
TRIALS_MAX = 20_000

MAX_TRIALS = 1_000_000


class _Parser(argparse.ArgumentParser):
    """argparse that reports a usage error in one line (it prints usage plus a line by default)."""

    def error(self, message: str):
        self.exit(EXIT_BAD_INPUT, f"{self.prog}: {one_line(message)} (see {self.prog} --help)\n")


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
# OpenCV takes a board's size as C ints; no printed board has a thousand corners a side
_board_count = _ranged(
    int, lambda v: 3 <= v <= 1000, "a board has 3 to 1000 inner corners each way"
)


def _folder(text: str) -> Path:
    """--out's folder; an empty one is refused (it would be the current folder, silently)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("is empty: give an output folder")
    return Path(text)


# what --force replaces, per verb: each verb's help says what its own --force does
_FORCE = {
    "run": "a run's own former results are replaced without it",
    "fit": "a former fit's are replaced without it",
    "discover": "a former discovery's are replaced without it",
    "camera": "a former calibration's are replaced without it",
    "iso230": "a former evaluation's are replaced without it",
    "acceptance": "a former test's are replaced without it",
}


def _out(p: argparse.ArgumentParser, default: str, verb: str) -> None:
    """--out and --force: each command writes to a folder of its own."""
    p.add_argument("--out", type=_folder, help=f"output folder (default ./calibench-out/{default})")
    if verb in ("montecarlo", "uncertainty"):
        force = (
            "replace the results --out holds (another command's, another study's) instead of "
            "refusing or resuming: the study starts anew"
        )
    else:
        force = (
            f"replace another command's results in --out instead of refusing ({_FORCE[verb]}; "
            "either is said in one line); a user's own files are never touched"
        )
    p.add_argument("--force", action="store_true", help=force)


def build_parser() -> argparse.ArgumentParser:
    """The ``calibench`` command's parser: every verb, its options and their checks.

    Returns
    -------
    argparse.ArgumentParser
        A parser whose usage errors exit with status 2 and one line on stderr; the verb is
        ``args.command``.
    """
    from calibench.scenarios.registry import NAMES, PLANNED

    p = _Parser(
        prog="calibench",
        description="Simulation-first test bench for calibrating measuring machines.",
    )
    from calibench import __version__

    p.add_argument("--version", action="version", version=f"calibench {__version__}")
    sub = p.add_subparsers(dest="command", required=True, parser_class=_Parser)

    _run_verb(sub)
    _fit_verb(sub)
    _montecarlo_verb(sub)
    _discover_verb(sub)
    _camera_verb(sub)
    _iso230_verb(sub)
    _acceptance_verb(sub)
    _uncertainty_verb(sub)
    p.epilog = f"Instruments: {', '.join(NAMES)}." + (
        f" Planned but not built yet: {', '.join(PLANNED)}." if PLANNED else ""
    )
    return p


def _run_verb(sub) -> None:
    """``calibench run``'s parser (simulate, calibrate, compare), added to ``sub``."""
    from calibench.scenarios.registry import takers

    arm = ", ".join(takers("--arm"))  # the instruments with an arm description
    views = ", ".join(takers("--save-images"))

    from calibench.scenarios.registry import NAMES

    names = ", ".join(NAMES)
    r = sub.add_parser(
        "run",
        help="simulate a scenario, calibrate, compare with the truth",
        description=f"Run a scenario ({names}) or all of them; writes DIR/report.json and "
        "DIR/run.rrd.",
    )
    r.add_argument("scenario", help=f"one of: {names}; or 'all'")
    r.add_argument("--seed", type=_seed, default=0, help="random seed (default 0)")
    _out(r, "<scenario>", "run")
    r.add_argument(
        "--fidelity",
        choices=("render", "analytic"),
        help="render: pixels through MuJoCo's renderer and the real detector; "
        "analytic: exact projection plus detector noise (default render where the scenario "
        "has a camera; the others have one fidelity, analytic)",
    )
    r.add_argument(
        "--config", type=Path, help="TOML file with one table per scenario overriding its defaults"
    )
    r.add_argument("--no-rrd", action="store_true", help="do not write the rerun recording")
    r.add_argument(
        "--save-images",
        type=_folder,
        metavar="DIR",
        help=f"{views}: also write the run's rendered views to DIR with truth.json (the "
        "camera's true intrinsics, each view's exact corners), to test a calibration tool on",
    )
    r.add_argument(
        "--arm",
        help=f"{arm}: ARM.toml or a built-in arm (arm-cmm, ur10) instead of the seed's arm",
    )


def _fit_verb(sub) -> None:
    """``calibench fit``'s parser (a model fitted to real recordings), added to ``sub``."""
    from calibench.scenarios.registry import FIT_MODELS

    arm = ", ".join(n for n, m in FIT_MODELS.items() if m == "arm")  # the arm's own options

    fit_names = ", ".join(FIT_MODELS)
    f = sub.add_parser(
        "fit",
        help="fit the scenario's error model to real recordings (CSV)",
        description="Fit the scenario's calibration model to recordings; writes DIR/fit.json. "
        f"Stages: one recording (x_cmd_mm, y_cmd_mm, x_meas_mm, y_meas_mm). {arm}: "
        "one or more training recordings (q1_deg.., x_mm, y_mm, z_mm), each with its "
        "own base frame, and recordings to test the result on.",
    )
    f.add_argument("scenario", help=f"one of: {fit_names}")
    f.add_argument("recordings", type=Path, nargs="+", metavar="RECORDING", help="CSV recording(s)")
    _out(f, "<scenario>-fit", "fit")
    f.add_argument(
        "--arm", help=f"{arm}: ARM.toml or a built-in arm (arm-cmm, ur10); default the seed's arm"
    )
    f.add_argument(
        "--test",
        type=Path,
        action="append",
        default=[],
        metavar="CSV",
        help=f"{arm}: a recording in the first training recording's frame to test on (repeatable)",
    )
    f.add_argument(
        "--test-new-frame",
        type=Path,
        action="append",
        default=[],
        metavar="CSV",
        help=f"{arm}: a recording from another setup: registered on 20 %% of its rows, tested on "
        "the rest (repeatable)",
    )
    f.add_argument(
        "--holdout",
        type=_fraction,
        metavar="F",
        help=f"{arm}: keep a fraction F of every training recording out of the fit (fixed seed)",
    )
    f.add_argument(
        "--leave-one-out",
        action="store_true",
        help=f"{arm}: each recording a session; each scored by a calibration on the others, its "
        "frame registered on 20 %% of its rows, figures on the rest (a new set-up's error)",
    )
    f.add_argument(
        "--model",
        choices=("geometry", "physics"),
        help=f"{arm}: geometry (kinematics, base, tool) or physics (and the joints' compliance "
        "under gravity); default physics when the arm has masses",
    )
    f.add_argument(
        "--effects",
        metavar="DISCOVERY.json|discover",
        help=f"{arm}: add the joint-angle effects a discover run found (transmission, "
        "eccentricity, "
        "a nonsmooth table) to the model; 'discover' runs the discovery here on the training rows",
    )


def _montecarlo_verb(sub) -> None:
    """``calibench montecarlo``'s parser (an accuracy study), added to ``sub``."""
    from calibench.scenarios.registry import takers

    arm = ", ".join(takers("--arm"))  # the instruments with an arm description

    from calibench.scenarios.registry import NAMES

    names = ", ".join(NAMES)
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
        "--scheduler",
        help="address of a Dask scheduler instead of local workers: tls://host:8786 with the "
        "--tls-* files (tcp:// is unauthenticated pickle: a trusted network only)",
    )
    for flag, key, what in (
        ("--tls-ca-file", "ca-file", "the certificate authority that signed the cluster's"),
        ("--tls-cert", "client.cert", "this client's certificate"),
        ("--tls-key", "client.key", "this client's private key"),
    ):
        mc.add_argument(
            flag,
            type=Path,
            help=f"--scheduler tls://: {what} (PEM; or Dask's config distributed.comm.tls.{key})",
        )
    mc.add_argument("--seed", type=_seed, default=0, help="study seed (default 0)")
    _out(mc, "<scenario>-montecarlo", "montecarlo")
    mc.add_argument(
        "--fidelity",
        choices=("render", "analytic"),
        default="analytic",
        help="sensor fidelity of each trial (default analytic)",
    )
    mc.add_argument("--arm", help=f"{arm}: ARM.toml or a built-in arm (arm-cmm, ur10)")
    mc.add_argument(
        "--config",
        type=Path,
        help="TOML overriding the scenario's defaults, as for run (its "
        "[scenario] table); the prior then draws around them",
    )


def _discover_verb(sub) -> None:
    """``calibench discover``'s parser (what the twin misses), added to ``sub``."""
    from calibench.scenarios.registry import takers

    arm = ", ".join(takers("--arm"))  # the instruments with an arm description

    d = sub.add_parser(
        "discover",
        help="where a recording disagrees with the twin, and which physics is missing",
        description="Compare a recording with the twin replaying its commands; locate the "
        "mismatch, name and fit the missing effects, show the held-out fit improve. "
        "Writes DIR/discovery.json and DIR/discovery.png.",
    )
    # the registry's instruments with a discovery adapter (discover.engine's supported()), read
    # here: importing the engine (its fits, scipy.signal) took 1.8 s of every command's start
    from calibench.scenarios.registry import instruments

    found = [i.name for i in instruments() if i.discovery]
    d.add_argument("scenario", help=f"one of: {', '.join(found)}")
    d.add_argument(
        "recording",
        type=Path,
        nargs="+",
        help=f"CSV in docs/formats.md's format for the scenario ({arm}: "
        "one or more, each with its own base frame; probe-scanner: one, or several of one "
        "machine with the plate turned on the table between them; the stages and stewart: "
        "one, or several of one machine, e.g. cold and warm, each stewart recording from its "
        "own tracker station)",
    )
    _out(d, "<scenario>-discover", "discover")
    d.add_argument(
        "--seed", type=_seed, default=0, help="seed of the permutation tests (default 0)"
    )
    d.add_argument(
        "--arm", help=f"{arm}: ARM.toml or a built-in arm (arm-cmm, ur10); default the seed's arm"
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


def _camera_verb(sub) -> None:
    """``calibench camera``'s parser (a camera from chessboard photos), added to ``sub``."""
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
    _out(c, "camera", "camera")


def _iso230_verb(sub) -> None:
    """``calibench iso230``'s parser (ISO 230-2 on a real run), added to ``sub``."""
    i = sub.add_parser(
        "iso230",
        help="ISO 230-2 evaluation of a real bidirectional run of one axis",
        description="Evaluate a bidirectional positioning run (target_mm, run, direction, and "
        "deviation_um or actual_mm) as ISO 230-2:2014; writes DIR/iso230.json and DIR/iso230.png.",
    )
    i.add_argument("run", type=Path, metavar="RUN.csv", help="the run, one row per reading")
    _out(i, "iso230", "iso230")


def _acceptance_verb(sub) -> None:
    """``calibench acceptance``'s parser (a standard's acceptance test on a twin), added to
    ``sub``."""
    from calibench.scenarios.acceptance import ALL_TESTS

    a = sub.add_parser(
        "acceptance",
        help="a standard's acceptance test run on an instrument's twin, before and after "
        "calibration",
        description="Run a standard's acceptance test (ISO 9283 for an arm used as a robot, ISO "
        "10360-12 for an articulated-arm CMM, ISO 230-2 for a stage's axes) on the instrument's "
        "twin before and after its "
        "calibration; writes DIR/acceptance.json. A config's [acceptance.mpe] table states the "
        "maker's limits by the figures' names.",
    )
    a.add_argument("scenario", help=f"the instrument ({_having('acceptance')})")
    a.add_argument("--test", required=True, choices=ALL_TESTS, help="the standard's test")
    a.add_argument("--config", type=Path, help="TOML overrides ([arm-cmm], [acceptance.mpe])")
    a.add_argument("--seed", type=_seed, default=0, help="the machine's and the test's draws")
    a.add_argument(
        "--recording",
        type=Path,
        action="append",
        default=[],
        metavar="CSV",
        help="iso9283: a real arm recording (docs/formats.md) whose repeated postures give the "
        "real arm's RP beside the twin's (repeatable)",
    )
    _out(a, "SCENARIO-acceptance", "acceptance")


def _tolerance(text: str) -> float:
    """--tolerance: a positive, finite number (the task's unit)."""
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
    if not (v > 0 and math.isfinite(v)):
        raise argparse.ArgumentTypeError(f"{text}: a positive number in the task's unit")
    return v


def _uncertainty_verb(sub) -> None:
    """``calibench uncertainty``'s parser (task-specific uncertainty, JCGM 101), added to
    ``sub``."""
    u = sub.add_parser(
        "uncertainty",
        help="the uncertainty of the calibrated instrument's task over its workspace "
        "(adaptive Monte Carlo, JCGM 101), beside the GUM framework's",
        description="Draw machines from the as-built distribution, calibrate each on simulated "
        "recordings and evaluate its compensated task error on a grid over the workspace, in "
        "batches until the numerical tolerance of every grid point's mean, standard uncertainty "
        "and 95 % interval holds (JCGM 101 7.9) or --trials-max; beside the GUM framework's "
        "answer and its validation (JCGM 101 8), and machines drawn afresh as a check. Writes "
        "DIR/uncertainty.json and DIR/uncertainty.png. Rerunning the same command resumes.",
    )
    u.add_argument("scenario", help=f"the instrument ({_having('uncertainty')})")
    u.add_argument(
        "--tolerance",
        type=_tolerance,
        help="the numerical tolerance, in the task's unit (default: half a unit of the last of "
        "u's first significant digit)",
    )
    u.add_argument(
        "--trials-max",
        type=_trials,
        default=TRIALS_MAX,
        help=f"the most trials (default {TRIALS_MAX})",
    )
    u.add_argument("--workers", type=_workers, help="local worker processes (default: all cores)")
    u.add_argument("--scheduler", help="address of a Dask scheduler instead of local workers")
    u.add_argument("--config", type=Path, help="TOML overrides (the instrument's table)")
    u.add_argument("--seed", type=_seed, default=0, help="study seed (default 0)")
    _out(u, "SCENARIO-uncertainty", "uncertainty")


def _having(field: str) -> str:
    """The instruments whose registry line has ``field`` (acceptance tests, an uncertainty
    task), named."""
    from calibench.scenarios.registry import instruments

    return ", ".join(row.name for row in instruments() if getattr(row, field))
