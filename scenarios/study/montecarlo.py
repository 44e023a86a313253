"""``calibench montecarlo``: accuracy studies of a scenario (CONTRACT: trials.parquet, summary.json).

Each trial draws the truth from the scenario's declared prior (its ``prior(config, rng)``) and
the noise from its sensor models, runs the pipeline, and returns plain data: one row with
``trial, seed, ok, error, elapsed_s`` and ``<name>.truth / .estimate / .std`` per parameter.
A trial is reproducible from (study seed, trial index) alone.

Execution goes through a ``concurrent.futures.Executor``: a local pool of spawned processes
(a forked child of a process with a GL context hangs), or a Dask cluster's executor with
``--scheduler``. Finished trials are appended to DIR/trials.jsonl at once (the journal: nothing
is lost on interruption, and a rerun of the same command skips them); trials.parquet and
summary.json are written from the journal.
"""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import dataclasses
import json
import math
import multiprocessing
import os
import re
import signal
import sys
import threading
import time
import traceback
from pathlib import Path

import numpy as np

from calibench.scenarios.report import BadInput

JOURNAL = "trials.jsonl"


def trial_seed(study_seed: int, index: int) -> int:
    """The trial's own seed, from the study's and its index (independent streams)."""
    return int(np.random.SeedSequence([int(study_seed), int(index)]).generate_state(1)[0])


def study_config(
    scenario: str, table: dict | None = None, arm: str | None = None, checked_only: bool = False
):
    """The scenario's config for a study: its defaults, overridden by ``table`` (the scenario's
    table of a ``--config`` TOML, checked as ``run`` checks it), then ``arm``. ``checked_only``:
    None once the config holds (raises :class:`BadInput` when it does not), for another process."""
    from calibench.scenarios.config import override
    from calibench.scenarios.registry import scenario as get

    config = override(get(scenario).config(), table or {}, scenario)
    config = config if arm is None else dataclasses.replace(config, arm=arm)
    return None if checked_only else config


def run_trial(
    scenario: str,
    study_seed: int,
    index: int,
    fidelity: str,
    arm: str | None = None,
    table: dict | None = None,
) -> dict:
    """One trial, in a worker process; never raises (a failure is a row with its error).
    ``table``: the study's config overrides (:func:`study_config`)."""
    os.environ.setdefault("MUJOCO_GL", "egl")  # a worker renders without a display

    seed = trial_seed(study_seed, index)
    row = {"trial": index, "seed": seed, "ok": True, "error": None}
    t0 = time.perf_counter()
    try:
        from calibench.scenarios.registry import scenario as get

        s = get(scenario)
        module = sys.modules[s.run.__module__]
        rng = np.random.default_rng(seed)
        config = module.prior(study_config(scenario, table, arm), rng)
        if hasattr(module, "trial_parameters"):
            params = module.trial_parameters(config, seed)
        else:
            rep = s.execute(config, seed, fidelity, None, False)
            params = rep.parameters
            for c in rep.checks:  # what the calibration achieved (a compensation, a pose error)
                row[f"check.{c.name}"] = float(c.value)
                row[f"check.{c.name}.ok"] = c.ok
        for p in params:
            row[f"{p.name}.truth"] = float(p.truth)
            row[f"{p.name}.estimate"] = float(p.estimate)
            row[f"{p.name}.std"] = None if p.std is None else float(p.std)
            row[f"{p.name}.unit"] = p.unit
            if p.crlb is not None:
                row[f"{p.name}.crlb"] = float(p.crlb)
    except Exception as e:  # noqa: BLE001 - recorded, the study goes on
        row["ok"] = False
        row["error"] = f"{type(e).__name__}: {e}".splitlines()[0]
        row["traceback"] = traceback.format_exc(limit=3)
    row["elapsed_s"] = time.perf_counter() - t0
    return row


def run_trials(
    scenario: str,
    study_seed: int,
    indices: list[int],
    fidelity: str,
    arm: str | None = None,
    table: dict | None = None,
) -> list[dict]:
    """Several trials in one task: millisecond trials would otherwise spend more time in
    inter-process traffic than in the estimator. One BLAS thread: a worker already has its core,
    and threaded BLAS on small matrices (the arm's QR at 200 postures) runs several times slower."""
    from threadpoolctl import threadpool_limits

    with threadpool_limits(1):
        return [run_trial(scenario, study_seed, i, fidelity, arm, table) for i in indices]


def chunk_size(n_todo: int, fidelity: str) -> int:
    """Trials per task: one for renders (seconds each, finest progress and resume), up to 16 for
    analytic trials, keeping 64 tasks or more so every worker stays busy to the end."""
    return 1 if fidelity == "render" else max(1, min(16, n_todo // 64))


def load_journal(out_dir: Path) -> dict[int, dict]:
    """Finished trials by index. A row an interruption tore is ignored; anything else that is not
    a trial of calibench's is bad input, said with the line."""
    path = out_dir / JOURNAL
    done = {}
    if not path.exists():
        return done
    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError):
        raise BadInput(
            f"{path} cannot be read as a journal of trials: remove it or use another --out"
        ) from None
    lines = text.splitlines()
    for k, line in enumerate(lines):
        if not line.strip():
            continue
        try:
            row = json.loads(line)
        except json.JSONDecodeError:
            if line.startswith('{"trial": '):
                continue  # a row torn by an interruption (a resume starts a fresh line after it)
            row = None
        if not (
            isinstance(row, dict)
            and isinstance(row.get("trial"), int)
            and row["trial"] >= 0
            and isinstance(row.get("ok"), bool)
            and "seed" in row
        ):
            raise BadInput(
                f"{path} line {k + 1} is not a finished trial of calibench's: the journal is corrupt or "
                "another program's; remove it or use another --out"
            )
        done[row["trial"]] = row
    return done


def _ignore_interrupts() -> None:
    """In a worker: Ctrl-C is the parent's to handle (one line), not a traceback per worker."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_IGN)


@contextlib.contextmanager
def _interrupt_flag():
    """An Event set by Ctrl-C while the study waits. A KeyboardInterrupt raised at an arbitrary
    bytecode can land while a future's lock is held (inside ``as_completed``), and the pool's
    manager thread then blocks the interpreter's exit forever; a flag is checked only where the
    loop can stop cleanly."""
    stop = threading.Event()
    if threading.current_thread() is not threading.main_thread():
        yield stop
        return
    old = signal.signal(signal.SIGINT, lambda signum, frame: stop.set())
    try:
        yield stop
    finally:
        signal.signal(signal.SIGINT, old)


def make_executor(workers: int | None, scheduler: str | None):
    """(executor, closer): a spawn process pool, or a Dask cluster's executor."""
    if scheduler:
        if not re.fullmatch(
            r"(tcp|tls|ucx|inproc|ws|wss)://[^\s/:]+(:\d+)?|[^\s/:]+:\d+", scheduler
        ):
            raise BadInput(f"--scheduler {scheduler}: not a scheduler's address (tcp://host:8786)")
        try:
            from distributed import Client
        except ImportError:
            raise BadInput(
                "--scheduler needs Dask distributed: pip install 'calibench[cluster]'"
            ) from None
        try:
            client = Client(scheduler, timeout="10s")
        except (OSError, ValueError, TimeoutError) as e:
            raise BadInput(
                f"--scheduler {scheduler}: cannot reach the Dask scheduler ({e})"
            ) from None
        return client.get_executor(), lambda interrupted=False: client.close()
    n = workers or os.cpu_count() or 1
    ex = cf.ProcessPoolExecutor(
        max_workers=n,
        mp_context=multiprocessing.get_context("spawn"),
        initializer=_ignore_interrupts,
    )

    def close(interrupted: bool = False) -> None:
        if not interrupted:
            ex.shutdown(wait=False, cancel_futures=True)
            return
        # a worker mid-chunk would hold the exit for its whole chunk: its trials are not kept anyway
        procs = list((getattr(ex, "_processes", None) or {}).values())
        for proc in procs:
            proc.terminate()
        for proc in procs:  # a worker that ignores SIGTERM (stuck in C) must not hold the exit
            proc.join(5)
            if proc.is_alive():
                proc.kill()
        # the workers are gone, so waiting is short; not waiting leaves the pool's manager thread
        # closing its wake-up pipe while the interpreter's exit writes to it (Python 3.11's
        # concurrent.futures race): a traceback after the one line, about 1 Ctrl-C in 20
        ex.shutdown(wait=True, cancel_futures=True)

    return ex, close


def run_study(
    scenario: str,
    trials: int,
    seed: int,
    fidelity: str,
    out_dir: Path,
    workers: int | None = None,
    scheduler: str | None = None,
    executor: cf.Executor | None = None,
    progress: bool | None = None,
    arm: str | None = None,
    table: dict | None = None,
) -> dict:
    """Run the missing trials of a study, journal them as they finish, write the outputs.
    ``table``: config overrides of the scenario (a ``--config`` file's table), the same for every
    trial and recorded in study.json, so a resumed study cannot mix two configs."""
    from calibench.scenarios.registry import NAMES

    if scenario not in NAMES:
        raise BadInput(f"unknown scenario {scenario!r} (available: {', '.join(NAMES)})")
    if trials < 1:
        raise BadInput("--trials must be at least 1")
    done = load_journal(out_dir)
    todo = [i for i in range(trials) if i not in done]
    # A local pool starts (and its workers load the scenario) while this process checks the config;
    # a Dask cluster is reached only once the config holds and there are trials to run.
    early = executor is None and scheduler is None and bool(todo)
    close = None
    failed = False
    try:
        checked = None
        if early:
            workers = min(workers or os.cpu_count() or 1, len(todo))  # no idle processes to start
            executor, close = make_executor(workers, None)
            for _ in range(workers):
                executor.submit(_load_scenario, scenario)
            # a worker, which loads the scenario anyway, checks the config: this process then
            # never imports the scenario's estimators, which on 2 cores would slow the workers' start
            checked = executor.submit(study_config, scenario, table, arm, checked_only=True)
        _prepare(scenario, seed, fidelity, out_dir, arm, table, checked)
        t0 = time.perf_counter()
        if todo:
            if executor is None:
                executor, close = make_executor(workers, scheduler)
            _run_todo(
                executor,
                scenario,
                seed,
                fidelity,
                out_dir,
                arm,
                table,
                trials,
                done,
                todo,
                progress,
                preload=close is not None and scheduler is None,
            )
    except (KeyboardInterrupt, BadInput):
        failed = True  # the workers' trials are not kept: stop them rather than wait for them
        raise
    finally:
        if close is not None:
            close(failed)
    rows = [done[i] for i in sorted(done) if i < trials]
    summary = summarise(scenario, rows, time.perf_counter() - t0)
    if rows and all(not r["ok"] and r["error"].startswith("LinAlgError") for r in rows):
        raise BadInput(
            f"every trial's estimate is singular: the {scenario} set-up cannot determine its parameters"
            + (" (is the arm degenerate: planar, or without length?)" if arm else "")
            + f"; e.g. {rows[0]['error']}"
        )
    if table and rows and not any(r["ok"] for r in rows):
        raise BadInput(
            f"every trial failed with the config's values (e.g. {rows[0]['error']}): the {scenario} "
            "set-up they describe cannot be calibrated"
        )
    if not summary["parameters"] and any(r["ok"] for r in rows):
        # an empty table is no result: the set-up leaves nothing to estimate (an arm of one joint,
        # whose every error the tracker's frame and the tool absorb); the journal stays
        raise BadInput(
            f"no trial estimated a parameter it could compare with the truth: the {scenario} set-up "
            "leaves nothing identifiable beside its frames"
            + (" (is the arm degenerate?)" if arm else "")
        )
    summary["resumed"] = len(rows) - sum(1 for i in todo if i in done)
    write_outputs(out_dir, rows, summary)
    return summary


def _import_writers() -> None:
    """Load what :func:`write_outputs` needs while the workers run: on 2 cores a fast study's
    outputs would otherwise wait a second or two for these imports after its last trial."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot  # noqa: F401
    import pyarrow.parquet  # noqa: F401
    import scipy.special  # noqa: F401

    from calibench.scenarios import rrlog  # noqa: F401


def _load_scenario(scenario: str) -> None:
    """In a worker, at its start: the scenario's module, imported before its first trials arrive."""
    from calibench.scenarios.registry import scenario as get

    get(scenario)


def _prepare(
    scenario: str, seed: int, fidelity: str, out_dir: Path, arm, table, checked=None
) -> None:
    """Check the config and the output folder (one study per folder), and record the study.
    ``checked``: the future of the config's check in a worker (:func:`study_config`), if any."""
    # a bad config is said once, before any trial
    if checked is None:
        study_config(scenario, table, arm)
    else:
        checked.result()
    out_dir.mkdir(parents=True, exist_ok=True)
    meta = {"scenario": scenario, "seed": seed, "fidelity": fidelity}
    if arm is not None:
        meta["arm"] = arm
    if table:
        meta["config"] = table
    meta_path = out_dir / "study.json"
    old = None
    if meta_path.exists():
        try:
            old = json.loads(meta_path.read_text())
        except (OSError, UnicodeDecodeError, json.JSONDecodeError):
            raise BadInput(
                f"{meta_path} is not a study's description (corrupt?): remove it or use another "
                "--out"
            ) from None
    if old is not None and old != meta:
        raise BadInput(
            f"{out_dir} holds a different study ({meta_path.read_text().strip()}); use another --out"
        )
    meta_path.write_text(json.dumps(meta) + "\n")


def _run_todo(
    executor,
    scenario,
    seed,
    fidelity,
    out_dir,
    arm,
    table,
    trials,
    done,
    todo,
    progress,
    preload: bool = False,
) -> None:
    """Run the trials ``todo`` on ``executor``, appending each finished one to the journal and to ``done``.
    ``preload``: the trials run in other processes, so this one is idle and may import the writers' modules."""
    bar = _progress(len(todo), trials - len(todo), progress)
    if preload:
        threading.Thread(target=_import_writers, daemon=True).start()
    try:
        path = out_dir / JOURNAL
        torn = path.exists() and path.stat().st_size and not path.read_bytes().endswith(b"\n")
        with open(path, "a") as journal:
            if torn:  # an interruption cut the last line: start a fresh one
                journal.write("\n")
            k = chunk_size(len(todo), fidelity)
            futures = [
                executor.submit(run_trials, scenario, seed, todo[j : j + k], fidelity, arm, table)
                for j in range(0, len(todo), k)
            ]
            with _interrupt_flag() as stop:
                pending = set(futures)
                while pending:
                    if stop.is_set():
                        raise KeyboardInterrupt
                    finished, pending = cf.wait(
                        pending, timeout=0.2, return_when=cf.FIRST_COMPLETED
                    )
                    for fut in sorted(finished, key=futures.index):
                        for row in fut.result():
                            journal.write(json.dumps(row) + "\n")
                            done[row["trial"]] = row
                        journal.flush()
                        bar.update(len(fut.result()))
    finally:
        bar.close()


def _progress(total: int, initial: int, enabled: bool | None):
    """A progress bar (trials/s, ETA) on an interactive terminal; silent otherwise and in CI."""
    from tqdm import tqdm

    if enabled is None:
        enabled = sys.stderr.isatty() and not os.environ.get("CI")
    return tqdm(
        total=total + initial, initial=initial, unit="trial", disable=not enabled, file=sys.stderr
    )


def chi2_ppf(p: np.ndarray, df: int) -> np.ndarray:
    """scipy.stats.chi2.ppf by its own formula, without importing scipy.stats (a second of
    start-up the summary of a fast study would wait for)."""
    from scipy.special import gammaincinv

    return 2 * gammaincinv(df / 2, p)


def binom_ppf(p: np.ndarray, n: int, prob: float) -> np.ndarray:
    """scipy.stats.binom.ppf: the least k with P(X <= k) >= p, X ~ Binomial(n, prob), (len(p),)
    floats."""
    from scipy.special import bdtr

    cdf = bdtr(np.arange(n + 1), n, prob)
    # a slack for a cdf rounded just below p; scipy's own search (Boost's) is not this code, so
    # the agreement is checked, not assumed: test_quantiles_equal_scipy_stats
    return np.searchsorted(cdf, np.asarray(p) * (1 - 1e-14)).astype(float)


def summarise(scenario: str, rows: list[dict], elapsed_s: float) -> dict:
    """Bias, RMSE, mean reported std and 95 % coverage of every parameter over the good trials."""
    good = [r for r in rows if r["ok"]]
    names = sorted({k[: -len(".estimate")] for r in good for k in r if k.endswith(".estimate")})
    params = []
    for n in names:
        err = np.array([r[f"{n}.estimate"] - r[f"{n}.truth"] for r in good if f"{n}.estimate" in r])
        std = np.array([r.get(f"{n}.std") for r in good if f"{n}.estimate" in r], dtype=object)
        has_std = all(s is not None for s in std)
        std = std.astype(float) if has_std else None
        unit = next((r[f"{n}.unit"] for r in good if f"{n}.unit" in r), "")
        crlb = np.array([r[f"{n}.crlb"] for r in good if f"{n}.crlb" in r])
        extra = {}
        if len(crlb) == len(err) and len(err) > 1:
            # efficiency: the bound's variance over the estimates' own (about their mean); the
            # sample variance has (n - 1) s^2 / sigma^2 ~ chi2(n - 1), which gives its interval
            eff = float(np.mean(crlb**2) / np.var(err, ddof=1))
            lo, hi = chi2_ppf(np.array([0.025, 0.975]), len(err) - 1) / (len(err) - 1)
            extra["crlb_std"] = float(np.sqrt(np.mean(crlb**2)))
            extra["efficiency"] = eff
            extra["efficiency_ci95"] = [eff * lo, eff * hi]
        params.append(
            {
                "name": n,
                "unit": unit,
                "n": int(len(err)),
                "bias": float(np.mean(err)),
                "rmse": float(np.sqrt(np.mean(err**2))),
                "mean_std": float(np.mean(std)) if has_std else None,
                "coverage_95": float(np.mean(np.abs(err) <= 1.96 * std)) if has_std else None,
                # where an honest coverage of 0.95 lands 95 % of the time with this many trials
                "coverage_95_expected": list(
                    binom_ppf(np.array([0.025, 0.975]), len(err), 0.95) / len(err)
                )
                if has_std
                else None,
                **extra,
            }
        )
    return {
        "scenario": scenario,
        "trials": len(rows),
        "failed": len(rows) - len(good),
        "elapsed_s": round(elapsed_s, 3),
        "parameters": params,
        "checks": _check_summary(good),
        "errors": sorted({r["error"] for r in rows if not r["ok"]})[:10],
    }


def _check_summary(good: list[dict]) -> list[dict]:
    """Each check's median, 95th percentile and worst value over the good trials, and the
    fraction of trials that failed it."""
    names = sorted(
        {
            k[len("check.") :]
            for r in good
            for k in r
            if k.startswith("check.") and not k.endswith(".ok")
        }
    )
    out = []
    for n in names:
        v = np.array([r[f"check.{n}"] for r in good if f"check.{n}" in r], float)
        ok = np.array([r[f"check.{n}.ok"] for r in good if f"check.{n}.ok" in r], bool)
        f = v[np.isfinite(v)]  # a value that is not a number failed its check, and is counted there
        stats = [
            float(g(f)) if len(f) else None
            for g in (np.median, lambda a: np.percentile(a, 95), np.max)
        ]
        out.append(
            {
                "name": n,
                "n": int(len(v)),
                "median": stats[0],
                "p95": stats[1],
                "max": stats[2],
                "failed_fraction": float(1 - ok.mean()),
            }
        )
    return out


def checks_table(summary: dict) -> str:
    """The checks' spread over the trials as markdown (empty when the trials report none)."""
    if not summary.get("checks"):
        return ""
    lines = ["| check | median | 95 % | worst | trials failing it |", "|---|---|---|---|---|"]
    f = lambda v: "-" if v is None else f"{v:.4g}"  # noqa: E731
    for c in summary["checks"]:
        lines.append(
            f"| {c['name']} | {f(c['median'])} | {f(c['p95'])} | {f(c['max'])} | {c['failed_fraction']:.1%} |"
        )
    return "\n".join(lines)


def summary_table(summary: dict) -> str:
    """The coverage table as markdown; efficiency with its 95 % interval where a CRLB exists."""
    f = lambda v: "" if v is None else f"{v:.4g}"  # noqa: E731
    lines = [
        "| parameter | unit | bias | rmse | mean std | coverage 95 % | efficiency (95 % CI) |",
        "|---|---|---|---|---|---|---|",
    ]
    for p in summary["parameters"]:
        eff = (
            ""
            if p.get("efficiency") is None
            else f"{p['efficiency']:.3f} ({p['efficiency_ci95'][0]:.2f}-{p['efficiency_ci95'][1]:.2f})"
        )
        cov = "" if p["coverage_95"] is None else f"{p['coverage_95']:.3f}"
        lines.append(
            f"| {p['name']} | {p['unit']} | {f(p['bias'])} | {f(p['rmse'])} | {f(p['mean_std'])} | "
            f"{cov} | {eff} |"
        )
    return "\n".join(lines)


def write_outputs(out_dir: Path, rows: list[dict], summary: dict) -> None:
    """Write trials.parquet, summary.json, study.png (and study.rrd) for the finished trials."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    keys = ["trial", "seed", "ok", "error", "elapsed_s"]
    cols = sorted(
        {
            k
            for r in rows
            for k in r
            if k not in keys and k != "traceback" and not k.endswith(".unit")
        }
    )
    table = {k: [r.get(k) for r in rows] for k in keys + cols}
    pq.write_table(pa.table(table), out_dir / "trials.parquet")
    (out_dir / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
    if summary["parameters"]:
        _figure(out_dir, rows, summary)
        _log(out_dir, summary)


def _log(out_dir: Path, summary: dict) -> None:
    """study.rrd: the figure and the coverage table, for the rerun viewer."""
    from calibench.scenarios import rrlog

    rec = rrlog.open_recording(out_dir / "study.rrd", f"calibench-{summary['scenario']}-study")
    try:
        text = (
            f"# {summary['scenario']}: {summary['trials']} trials\n\n{summary_table(summary)}\n\n"
            f"{checks_table(summary)}"
        )
        rrlog.log_text(rec, "study/summary", text)
        rrlog.log_figure(rec, "study/figure", out_dir / "study.png")
    finally:
        rrlog.close(rec)


def _figure(out_dir: Path, rows: list[dict], summary: dict) -> None:
    """study.png: normalised errors against N(0, 1), and each parameter's coverage."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    good = [r for r in rows if r["ok"]]
    with_std = [p for p in summary["parameters"] if p["coverage_95"] is not None]
    # margins set by hand: the constrained layout measured every rotated name, a third of the time
    fig, axes = plt.subplots(1, 2, figsize=(14, 4.5))
    fig.subplots_adjust(left=0.05, right=0.99, top=0.93, bottom=0.25, wspace=0.15)
    ax = axes[0]
    z = [
        (r[f"{p['name']}.estimate"] - r[f"{p['name']}.truth"]) / r[f"{p['name']}.std"]
        for p in with_std
        for r in good
        if r.get(f"{p['name']}.std")
    ]
    if z:
        ax.hist(
            np.clip(z, -6, 6),
            bins=60,
            density=True,
            color="tab:blue",
            alpha=0.6,
            label="(estimate - truth) / std",
        )
        x = np.linspace(-6, 6, 200)
        ax.plot(x, np.exp(-x * x / 2) / math.sqrt(2 * math.pi), "k", label="N(0, 1): an honest std")
        ax.legend()
    ax.set(title=f"{summary['scenario']}: {len(good)} trials", xlabel="normalised error")
    ax = axes[1]
    names = [p["name"] for p in with_std]
    ax.bar(range(len(names)), [p["coverage_95"] for p in with_std], color="tab:green")
    ax.axhspan(0.93, 0.97, color="k", alpha=0.1, label="0.93-0.97")
    ax.set_xticks(range(len(names)), names, rotation=90, fontsize=7)
    ax.set(ylim=(0, 1.05), ylabel="coverage of +-1.96 std", title="coverage per parameter")
    ax.legend(loc="lower right")
    fig.savefig(out_dir / "study.png", dpi=90)
    plt.close(fig)
