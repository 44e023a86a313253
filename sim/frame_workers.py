"""Frames developed on worker threads while the GL thread captures the next.

A rendered frame is two kinds of work: the capture, which needs the GL context and so the thread
that made it (the render, its read-back, the noise drawn in the frames' order), and the
development, which needs neither (the lens, the blur, the quantisation, the detection). On the
CPU, llvmpipe's capture keeps one core busy (it hardly gains from more threads); on a GPU the
capture is quick and the development is the frame's cost. Either way the other cores can develop
the frames already captured: numpy's large operations, OpenCV and scipy's sparse products leave
Python's lock while they work. The results are those of developing in turn, bit for bit.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterable
from concurrent.futures import Future, ThreadPoolExecutor
from typing import TypeVar

C = TypeVar("C")
R = TypeVar("R")

# frames captured and not yet developed, per worker: enough to keep each busy, few enough that a
# full supersampled frame (16 MB) does not pile up when the capture outruns the development
IN_FLIGHT_PER_WORKER = 2


def usable_cores() -> int:
    """The cores this process may run on (its affinity, where the system says; else all)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def frame_workers() -> int:
    """Developing threads for a single run: one core is the capturing thread's."""
    return usable_cores() - 1


def develop_all(captures: Iterable[C], develop: Callable[[C], R], workers: int) -> list[R]:
    """``develop(c)`` of each capture, in the captures' order.

    Parameters
    ----------
    captures : iterable
        The captured frames; iterated on this thread (the GL context's), which it may advance.
    develop : callable
        A capture to its result; must not touch GL or the generator that drew the noise.
    workers : int
        Developing threads; 0 develops each capture on this thread as it comes (a study's trial,
        whose worker processes fill the cores already).

    Returns
    -------
    list
        The results, one per capture, in order.
    """
    if workers <= 0:
        return [develop(c) for c in captures]
    pending: list[Future] = []
    limit = IN_FLIGHT_PER_WORKER * workers
    with ThreadPoolExecutor(workers, thread_name_prefix="develop") as pool:
        for c in captures:
            pending.append(pool.submit(develop, c))
            if len(pending) > limit:  # hold the capture back until the oldest in flight is done
                pending[-limit - 1].result()
        return [f.result() for f in pending]
