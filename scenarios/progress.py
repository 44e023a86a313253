"""A long command's progress on stderr: one bar on a terminal, a plain line at least every
:data:`INTERVAL_S` elsewhere (a CI log, a pipe), and the final line once.

The command opens one :class:`Progress` (the verb's handler, or ``run_study``); the code it calls
reports through this module's functions (:func:`expect`, :func:`step`, :func:`advance`,
:func:`stage`, :func:`steps`), which go to that bar, or nowhere when there is none. A study's
worker has none: it never draws (a spawned worker is another process, and a trial run on a
thread of this one runs under :func:`quiet`), so a terminal shows the study's bar alone.

What a line says: the steps done of those expected, the step and stage now running, the time
taken, and how long is left once that is known: from the steps' times (the first step's, weighed
by each step's expected share of the work), or else from a documented estimate of the whole
(each instrument's ``run_s`` in :mod:`calibench.scenarios.registry`). Nothing is said during the
first :data:`GRACE_S` (a short command stays silent), and nothing ever touches a random draw:
results are the same with or without it.

``CALIBENCH_PROGRESS=off|plain|bar`` sets the mode whatever stderr is.
"""

from __future__ import annotations

import contextlib
import os
import sys
import threading
import time
from collections.abc import Iterable, Iterator, Sized

INTERVAL_S = 30.0  # off a terminal, a line at least this often
GRACE_S = 10.0  # off a terminal, nothing before this: a short command's stderr stays its own
BAR_DELAY_S = 1.0  # on a terminal, no bar flashes for a command shorter than this
REFRESH_S = 0.5  # a bar's clock moves while one long step runs
DRAW_EVERY_S = 0.1  # a loop of thousands of steps draws the bar at most this often
CLOCK = time.monotonic  # tests replace it: a test waits for no real interval
HEARTBEAT = True  # a thread says the progress while a step runs (tests turn it off)
ENV = "CALIBENCH_PROGRESS"


_quiet = threading.local()  # .on: this thread runs a worker's trials, which report nothing
_open: list[Progress] = []  # the command's progress: one a process
_lock = threading.RLock()  # the command's threads (camera's detectors) report at once


def duration(seconds: float) -> str:
    """A time as a line says it.

    Parameters
    ----------
    seconds : float
        The time, s.

    Returns
    -------
    str
        ``"12 s"``, ``"3 min 05 s"`` or ``"1 h 02 min"``.
    """
    s = max(int(round(seconds)), 0)
    if s < 60:
        return f"{s} s"
    if s < 3600:
        return f"{s // 60} min {s % 60:02d} s"
    return f"{s // 3600} h {s % 3600 // 60:02d} min"


def _mode(enabled: bool | None, stream) -> str:
    """``off``, ``plain`` or ``bar``: the environment's choice, then the caller's, then a bar
    where stderr is an interactive terminal outside CI."""
    if getattr(_quiet, "on", False) or enabled is False:
        return "off"
    said = os.environ.get(ENV, "").strip().lower()
    if said in ("off", "plain", "bar"):
        return said
    try:
        tty = stream.isatty()
    except (AttributeError, ValueError):  # a closed or a bare stream: a log
        tty = False
    return "bar" if tty and not os.environ.get("CI") else "plain"


class Progress:
    """The progress of one command, as a context manager (one open at a time in a process; a
    second, or one opened by a worker's thread, says nothing).

    Parameters
    ----------
    what : str
        What runs, as the lines name it (``"montecarlo arm-cmm"``).
    estimate_s : float, optional
        How long the whole usually takes (the registry's ``run_s``), said until a step's own time
        is known.
    enabled : bool, optional
        False: silent; True or None: by :func:`_mode` (a bar on a terminal, lines elsewhere).
    stream : file, optional
        Where it writes (default: ``sys.stderr`` at the time it opens).
    """

    def __init__(
        self, what: str, estimate_s: float | None = None, enabled: bool | None = None, stream=None
    ) -> None:
        self.what = what
        self.estimate_s = estimate_s
        self.stream = sys.stderr if stream is None else stream
        self.mode = _mode(enabled, self.stream)
        self.n: int | None = None
        self.unit = "steps"
        self.weights: list[float] = []
        self.done = self.base = 0  # base: the steps finished before this run (a resumed study)
        self.label = ""
        self.stages: list[str] = []  # what the running step does, outermost first
        self.inner: tuple[str, int, int | None, float] | None = None
        self.t0 = self.t_steps = self.t_done = CLOCK()
        self.last: float | None = None  # when a plain line was last said (None: not yet)
        self.estimated = False  # a line has said how long is left
        self.drawn = False  # the bar is on the terminal
        self.drawn_at = -1.0  # when it was last drawn (DRAW_EVERY_S)
        self.mid_line = False  # the command printed part of a line: no bar until its end
        self._stop = threading.Event()
        self._streams: tuple | None = None  # sys.stdout and sys.stderr while the bar is up

    def __enter__(self) -> Progress:
        with _lock:
            if self.mode != "off" and _open:
                self.mode = "off"  # the command's own bar is already open: one bar
            if self.mode != "off":
                _open.append(self)
        if self.mode == "bar":
            # what the command prints (its tables, a warning) clears the bar first, so no line
            # runs into it; the bar comes back under them at the next tick
            self._streams = (sys.stdout, sys.stderr)
            sys.stdout, sys.stderr = _Clearing(sys.stdout, self), _Clearing(sys.stderr, self)
        if self.mode != "off" and HEARTBEAT:
            threading.Thread(target=self._beat, daemon=True, name="calibench-progress").start()
        return self

    def __exit__(self, kind, value, tb) -> None:
        self.close(ok=kind is None)

    def _beat(self) -> None:
        """Say the progress while one step runs for minutes (the heartbeat thread)."""
        while not self._stop.wait(REFRESH_S if self.mode == "bar" else 1.0):
            self.tick()

    def expect(self, n: int, unit: str, weights: list[float] | None = None, done: int = 0) -> None:
        """Steps to come: ``n`` of ``unit``, ``done`` of them finished before (a resumed study's
        trials); ``weights``: each step's share of the work (a fold's training rows), whose sum
        over the steps finished scales their time to the rest."""
        with _lock:
            self.n, self.unit, self.done = n, unit, done
            self.weights = list(weights) if weights is not None else [1.0] * n
            self.t_steps, self.base = CLOCK(), done
            self.t_done = self.t_steps
            self.label, self.stages, self.inner = "", [], None  # what set them up is done
        self.tick()

    def step(self, label: str) -> None:
        """The step now running (``"ur10_B.csv left out"``); its stage starts empty."""
        with _lock:
            self.label, self.stages, self.inner = label, [], None
        self.tick()

    def stage(self, text: str) -> None:
        """What the running step does now (``"calibrating"``)."""
        with _lock:
            self.stages, self.inner = [text], None
        self.tick()

    def advance(self, k: int = 1) -> None:
        """``k`` steps finished."""
        with _lock:
            self.done += k
            self.t_done = CLOCK()  # when the last step finished
            self.label, self.stages, self.inner = "", [], None
        self.tick()

    def left_s(self, now: float) -> float | None:
        """Seconds left: from the finished steps' time and their weights, else from
        :attr:`estimate_s`; None while neither is known."""
        if self.n is not None and self.done >= self.n:
            return None  # the steps are done; what follows them (the outputs) has no estimate
        if self.n is not None and self.done > self.base:
            # the steps finished in this run (a resumed study's earlier ones took no time here)
            first, last = self.base, min(self.done, len(self.weights))
            spent = sum(self.weights[first:last])
            rest = sum(self.weights[last:])
            if spent <= 0:
                return None
            # the finished steps' pace, less the time the running step has had: counts down
            # while it keeps that pace; once it is slower, its own time so far says the pace
            left = (self.t_done - self.t_steps) * rest / spent - (now - self.t_done)
            return left if left > 0 else (now - self.t_steps) * rest / spent
        if self.estimate_s is not None and now - self.t0 < self.estimate_s:
            return self.estimate_s - (now - self.t0)
        return None

    def text(self, now: float) -> str:
        """The status: steps, the running step and its stage, the time taken, the time left."""
        parts = []
        if self.n is not None:
            parts.append(f"{self.done}/{self.n} {self.unit}")
        running = ": ".join(t for t in (self.label, *self.stages) if t)
        if self.inner is not None:
            what, k, n, _ = self.inner
            running = ": ".join(t for t in (running, f"{what} {k}/{n or '?'}") if t)
        if running:
            parts.append(running)
        parts.append(duration(now - self.t0))
        left = self.left_s(now)
        said = ", ".join(parts)
        return said if left is None else f"{said}; about {duration(left)} left"

    def tick(self) -> None:
        """Draw the bar, or say a plain line when one is due: the first after :data:`GRACE_S`,
        one as soon as the time left is first known, then one every :data:`INTERVAL_S`."""
        if self.mode == "off":
            return
        with _lock:
            now = CLOCK()
            if self.mode == "bar":
                due = now - self.t0 >= BAR_DELAY_S and now - self.drawn_at >= DRAW_EVERY_S
                if due and not self.mid_line:
                    self._draw(now)
                    self.drawn_at = now
                return
            if now - self.t0 < GRACE_S:
                return
            knows = self.left_s(now) is not None
            if self.last is None or now - self.last >= INTERVAL_S or (knows and not self.estimated):
                self._say(f"calibench: {self.what}: {self.text(now)}")
                self.last, self.estimated = now, self.estimated or knows

    def _say(self, line: str) -> None:
        """One line on the stream (a reader gone: nothing to say)."""
        try:
            print(line, file=self.stream, flush=True)
        except (OSError, ValueError):
            self.mode = "off"

    def _width(self) -> int:
        try:
            return os.get_terminal_size(self.stream.fileno()).columns or 80
        except (OSError, ValueError, AttributeError):
            return 80

    def _draw(self, now: float) -> None:
        """The bar, over the line it is on (the cursor stays at its start: a line printed next
        would overwrite it from the left: :class:`_Clearing` clears it first)."""
        width = self._width()
        fraction = None
        if self.n:
            fraction = min(self.done / self.n, 1.0)
        elif self.inner is not None and self.inner[2]:
            fraction = min(self.inner[1] / self.inner[2], 1.0)
        bar = ""
        if fraction is not None:
            full = int(round(20 * fraction))
            bar = f" [{'#' * full}{'.' * (20 - full)}]"
        line = f"{self.what}{bar}: {self.text(now)}"[: max(width - 1, 10)]
        try:
            self.stream.write(f"\r{line}\x1b[K\r")
            self.stream.flush()
            self.drawn = True
        except (OSError, ValueError):
            self.mode = "off"

    def clear(self) -> None:
        """Take the bar off the terminal (drawn again at the next tick, under what was printed)."""
        with _lock:
            if self.mode == "bar" and self.drawn:
                try:
                    self.stream.write("\r\x1b[K")
                    self.stream.flush()
                except (OSError, ValueError):
                    self.mode = "off"
                self.drawn = False

    def close(self, ok: bool = True) -> None:
        """End: the bar cleared; the final line said once, when the command finished and
        anything was said before (a short command stays silent, a failed one ends on its own
        line)."""
        self._stop.set()
        with _lock:
            if self in _open:
                _open.remove(self)
            if self._streams is not None:
                if isinstance(sys.stdout, _Clearing) and sys.stdout.progress is self:
                    sys.stdout = self._streams[0]
                if isinstance(sys.stderr, _Clearing) and sys.stderr.progress is self:
                    sys.stderr = self._streams[1]
                self._streams = None
            if self.mode == "off":
                return
            self.clear()
            # on a terminal the command's own output is the last word; a log's lines end on
            # one saying the whole time
            if ok and self.mode == "plain" and self.last is not None:
                now = CLOCK()
                steps = f"{self.done} {self.unit}, " if self.n is not None else ""
                self._say(f"calibench: {self.what}: done, {steps}{duration(now - self.t0)}")
            self.mode = "off"


class _Clearing:
    """sys.stdout or sys.stderr while a bar is up: a write clears the bar first."""

    def __init__(self, stream, progress: Progress) -> None:
        self.stream, self.progress = stream, progress

    def write(self, text: str) -> int:
        """Clear the bar, then write ``text`` to the stream; no bar is drawn again until the
        line is ended (``print`` writes the text, then its newline: a bar between the two
        would draw over the text)."""
        if not text:
            return 0
        with _lock:
            self.progress.clear()
            self.progress.mid_line = not text.endswith("\n")
            return self.stream.write(text)

    def __getattr__(self, name: str):
        return getattr(self.stream, name)


def _current() -> Progress | None:
    """The command's progress, unless this thread runs a worker's trials."""
    if getattr(_quiet, "on", False) or not _open:
        return None
    return _open[-1]


def expect(n: int, unit: str, weights: list[float] | None = None, done: int = 0) -> None:
    """:meth:`Progress.expect` of the command's progress, if any."""
    p = _current()
    if p is not None:
        p.expect(n, unit, weights, done)


def step(label: str) -> None:
    """:meth:`Progress.step` of the command's progress, if any."""
    p = _current()
    if p is not None:
        p.step(label)


def stage(text: str) -> None:
    """:meth:`Progress.stage` of the command's progress, if any."""
    p = _current()
    if p is not None:
        p.stage(text)


@contextlib.contextmanager
def staged(text: str):
    """The block is a stage of the running one (``"calibrating"`` inside ``"discovering the
    effects"``: the line says both); the stage before is back when it ends.

    Parameters
    ----------
    text : str
        What the block does.
    """
    p = _current()
    if p is None:
        yield
        return
    with _lock:
        was = list(p.stages)
        p.stages, p.inner = [*was, text], None
    p.tick()
    try:
        yield
    finally:
        with _lock:
            p.stages = was


def advance(k: int = 1) -> None:
    """:meth:`Progress.advance` of the command's progress, if any."""
    p = _current()
    if p is not None:
        p.advance(k)


def steps(items: Iterable, what: str, total: int | None = None) -> Iterator:
    """``items``, each reported to the command's progress as ``what k/n`` of the running stage.

    Parameters
    ----------
    items : iterable
        What is iterated (the views rendered, the circles found).
    what : str
        Its name in the line.
    total : int, optional
        How many (default ``len(items)`` where it has one).

    Yields
    ------
    object
        Each item, as ``items`` gives it.
    """
    p = _current()
    if p is None:
        yield from items
        return
    n = total if total is not None else (len(items) if isinstance(items, Sized) else None)
    t0 = CLOCK()
    with _lock:
        p.inner = (what, 0, n, t0)
    try:
        for k, item in enumerate(items):
            yield item
            with _lock:
                p.inner = (what, k + 1, n, t0)
            p.tick()
    finally:
        with _lock:
            if p.inner is not None and p.inner[0] == what:
                p.inner = None


@contextlib.contextmanager
def part(label: str):
    """A part of the command (``run all``'s scenario): a step of its progress, where the command
    expects steps; nothing otherwise (``run S``'s one scenario is the command itself)."""
    p = _current()
    if p is None or p.n is None:
        yield
        return
    p.step(label)
    yield
    p.advance()


def for_command(args) -> Progress:
    """The progress of a ``calibench`` command, by its parsed arguments (``main`` opens it
    around the verb's handler): what it is called and, where known, its steps and estimate.

    Parameters
    ----------
    args : argparse.Namespace
        The command's parsed arguments.

    Returns
    -------
    Progress
        Not yet open.
    """
    command, scenario = args.command, getattr(args, "scenario", None)
    what = " ".join(x for x in (command, scenario) if x)
    if getattr(args, "leave_one_out", False):
        what += " --leave-one-out"
    p = Progress(what)
    if command == "run":
        from calibench.scenarios.registry import instruments

        runs = {i.name: i.run_s for i in instruments() if scenario in ("all", i.name)}
        # the estimate is of a run with its renders; an analytic stage's is not known
        if getattr(args, "fidelity", None) in (None, "render") and runs:
            p.estimate_s = sum(runs.values())
        if scenario == "all":
            p.n, p.unit, p.weights = len(runs), "scenarios", list(runs.values())
    elif command == "camera":
        p.n, p.unit = len(args.images), "photos"
        p.weights = [1.0] * p.n
    return p


@contextlib.contextmanager
def quiet():
    """This thread reports nothing while the block runs: a worker's trials, on a spawned
    process's thread, a Dask worker's, or a thread of the study's own process (whose bar then
    stays the study's alone)."""
    was = getattr(_quiet, "on", False)
    _quiet.on = True
    try:
        yield
    finally:
        _quiet.on = was
