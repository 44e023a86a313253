"""Where a study's trials run: a local pool of spawned processes (a forked child of a process
with a GL context hangs), or a Dask cluster's executor with ``--scheduler``; and Ctrl-C while
the study waits on them."""

from __future__ import annotations

import concurrent.futures as cf
import contextlib
import logging
import multiprocessing
import os
import re
import signal
import threading
import time
from pathlib import Path

from calibench.errors import BadInput


def _start_worker(renders: bool = True) -> None:
    """In a worker: Ctrl-C is the parent's to handle (one line), not a traceback per worker; and
    the worker dies with its parent (a parent killed outright, SIGKILL, cannot stop its workers:
    each watches for being handed to another parent and exits). A worker that never renders
    loads MuJoCo without its GL (MUJOCO_GL=disable: PyOpenGL's EGL is 90 ms of its start)."""
    import signal
    import sys

    if not renders and "mujoco" not in sys.modules:
        os.environ["MUJOCO_GL"] = "disable"
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    parent = os.getppid()

    def watch() -> None:
        while True:
            time.sleep(0.5)
            if os.getppid() != parent:
                os._exit(1)

    threading.Thread(target=watch, daemon=True, name="calibench-parent-watch").start()


@contextlib.contextmanager
def interrupt_flag():
    """An Event set by Ctrl-C while the study waits. A KeyboardInterrupt raised at an arbitrary
    bytecode can land while a future's lock is held (inside ``as_completed``), and the pool's
    manager thread then blocks the interpreter's exit forever; a flag is checked only where the
    loop can stop cleanly.

    Yields
    ------
    threading.Event
        Set once Ctrl-C or SIGTERM came (never set outside the main thread, where no signal
        can be caught); the previous handlers are back when the block ends.
    """
    stop = threading.Event()
    if threading.current_thread() is not threading.main_thread():
        yield stop
        return
    old = signal.signal(signal.SIGINT, lambda signum, frame: stop.set())
    # SIGTERM (timeout, systemd, docker) ends a study as Ctrl-C does: one line, the journal kept
    old_term = signal.signal(signal.SIGTERM, lambda signum, frame: stop.set())
    try:
        yield stop
    finally:
        signal.signal(signal.SIGINT, old)
        signal.signal(signal.SIGTERM, old_term)


# a local pool's workers are started with these (make_executor)
WORKER_ENV = {"PYTHONSAFEPATH": "1", "OPENBLAS_NUM_THREADS": "1"}

CONNECT_S = 10.0  # to reach a scheduler and hear it answer as one


def _connect(make_client, scheduler: str):
    """A Dask client of ``scheduler``, or BadInput within about :data:`CONNECT_S`: a listener
    that accepts and never speaks Dask held the client's own timeout open for over a minute, so
    the connection is made on a thread given that long."""
    got: dict = {}

    def connect() -> None:
        try:
            got["client"] = make_client(scheduler, f"{CONNECT_S:g}s")
        except Exception as e:  # noqa: BLE001 - said as bad input below
            got["error"] = e

    t = threading.Thread(target=connect, daemon=True, name="calibench-dask-connect")
    t.start()
    t.join(CONNECT_S + 5.0)
    if "client" in got:
        return got["client"]
    why = got.get("error") or f"no answer as a Dask scheduler within {CONNECT_S + 5.0:g} s"
    raise BadInput(f"--scheduler {scheduler}: cannot reach the Dask scheduler ({why})")


def _security(scheduler: str, tls: dict):
    """Dask's Security for ``scheduler``: for tls://, the given files over Dask's config, and a
    clear line when neither says where they are; None for another protocol (Dask's config)."""
    if not scheduler.startswith("tls://"):
        if any(tls.values()):
            raise BadInput(f"--tls-* files given, but --scheduler {scheduler} is not tls://")
        return None
    import dask.config
    from distributed.security import Security

    def pick(key: str, conf: str):
        v = tls.get(key) or dask.config.get(f"distributed.comm.tls.{conf}", None)
        if v and not Path(v).is_file():
            raise BadInput(f"--scheduler {scheduler}: {v} (TLS {key}) is not a file")
        return str(v) if v else None

    ca, cert, key = (
        pick("ca_file", "ca-file"),
        pick("cert", "client.cert"),
        pick("key", "client.key"),
    )
    if not (ca and cert):
        raise BadInput(
            f"--scheduler {scheduler}: TLS needs the cluster's certificate authority and this "
            "client's certificate: --tls-ca-file, --tls-cert (and --tls-key unless the "
            "certificate holds it), or Dask's config distributed.comm.tls.ca-file and "
            ".client.cert/.client.key"
        )
    return Security(
        tls_ca_file=ca, tls_client_cert=cert, tls_client_key=key, require_encryption=True
    )


def make_executor(
    workers: int | None,
    scheduler: str | None,
    tls: dict | None = None,
    warm=None,
    renders: bool = True,
):
    """A spawn process pool, or a Dask cluster's executor.

    Parameters
    ----------
    workers : int, optional
        Local worker processes (default: one per core); ignored with ``scheduler``.
    scheduler : str, optional
        A Dask scheduler's address (``tcp://host:8786``, ``tls://...``).
    tls : dict, optional
        For ``tls://``: ``ca_file``, ``cert``, ``key`` paths (None each: Dask's config
        ``distributed.comm.tls.ca-file``, ``.client.cert``, ``.client.key``).
    warm : callable, optional
        With ``scheduler``: run once on every worker of the cluster as soon as it is reached
        (the scenario's imports), while this process prepares the study.
    renders : bool
        Whether the trials render; a local pool's workers load no GL when they do not.

    Returns
    -------
    executor : concurrent.futures.Executor
        Where the trials run; its workers ignore Ctrl-C (the parent says it in one line).
    close : callable
        ``close(interrupted=False)`` releases the executor; ``interrupted`` stops the local
        workers at once instead of letting them finish their tasks.

    Raises
    ------
    BadInput
        ``scheduler`` is not an address, Dask distributed is not installed, or the scheduler
        cannot be reached.
    """
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
        security = _security(scheduler, tls or {})
        client = _connect(
            lambda address, timeout: Client(address, timeout=timeout, security=security), scheduler
        )
        warming = []
        if warm is not None:  # held until close: a released future's task is cancelled
            warming = [
                client.submit(warm, workers=[w], pure=False, allow_other_workers=False)
                for w in client.scheduler_info().get("workers", {})
            ]

        def close_client(interrupted: bool = False) -> None:
            warming.clear()
            client.close()

        executor = client.get_executor()
        executor.dask_workers = len(client.scheduler_info().get("workers", {}))
        executor.workers_now = lambda: len(client.scheduler_info().get("workers", {}))
        # a scheduler gone mid-study is said in one line (cluster_result), not in Dask's dozens
        for name in ["distributed", *logging.root.manager.loggerDict]:  # each has its own level
            if name.split(".")[0] == "distributed":
                logging.getLogger(name).setLevel(logging.CRITICAL)
        return executor, close_client
    n = workers or os.cpu_count() or 1
    # The workers' environment, for the pool's life only (a program this one starts later keeps
    # the user's settings). A spawned worker starts as `python -c ...`, whose import path begins
    # with the current folder: a socket.py or pickle.py there would run in every worker before
    # multiprocessing sets the path it was given; Python 3.11's safe path leaves the folder out.
    # Each worker's trials use one BLAS thread (run_trials), so OpenBLAS need not start a thread
    # per core when numpy loads: 80 ms of CPU a worker, which on 2 cores the start waits for.
    saved = {k: os.environ.get(k) for k in WORKER_ENV}
    os.environ.update(WORKER_ENV)
    ex = cf.ProcessPoolExecutor(
        max_workers=n,
        mp_context=multiprocessing.get_context("spawn"),
        initializer=_start_worker,
        initargs=(renders,),
    )

    def close(interrupted: bool = False) -> None:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v
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


NO_WORKERS_S = 60.0  # an adaptive cluster may have none for a moment while it scales
LOST = (
    "the Dask cluster went away mid-study ({why}): finished trials are kept; start its "
    "scheduler and workers again and rerun the same command to resume"
)


def cluster_result(fut: cf.Future):
    """A finished future's result; BadInput where a Dask cluster lost it (its scheduler killed:
    the future cancelled, the connection closed), which is the environment's end, not a trial's.
    """
    try:
        return fut.result()
    except cf.CancelledError:
        raise BadInput(LOST.format(why="its scheduler stopped")) from None
    except OSError as e:
        if type(e).__name__ != "CommClosedError":  # Dask's: the scheduler's connection closed
            raise
        raise BadInput(LOST.format(why="its scheduler stopped")) from None


class WorkersGone:
    """Watches a Dask cluster's workers while a study waits on it: a cluster with none for
    :data:`NO_WORKERS_S` is said in one line (BadInput) instead of waiting silently for ever;
    a local pool is never watched."""

    def __init__(self, executor: object) -> None:
        self.count = getattr(executor, "workers_now", None)
        self.since: float | None = None

    def check(self) -> None:
        """BadInput once the cluster has had no worker for :data:`NO_WORKERS_S`."""
        if self.count is None:
            return
        try:
            n = self.count()
        except Exception:  # noqa: BLE001 - the scheduler unreachable: its futures say so
            return
        if n:
            self.since = None
            return
        self.since = self.since or time.monotonic()
        if time.monotonic() - self.since > NO_WORKERS_S:
            raise BadInput(LOST.format(why=f"no worker left for {NO_WORKERS_S:g} s"))
