"""``calibench``'s ``main``: parse, check --out, run the verb's handler, and turn what went wrong
into docs/formats.md's exit statuses (2 bad input in one line, 3 an internal error with the
traceback in OUT/error.log, 130 interrupted); and ``command``, the executable around it."""

from __future__ import annotations

import atexit
import errno
import os
import signal
import sys
import threading
import warnings
from pathlib import Path

from calibench.scenarios.cli import claims, folders, standards, verbs
from calibench.scenarios.cli.parser import build_parser
from calibench.scenarios.cli.status import (
    EXIT_BAD_INPUT,
    EXIT_INTERNAL,
    EXIT_INTERRUPTED,
    EXIT_OK,
    one_line,
)
from calibench.scenarios.progress import for_command


def main(argv: list[str] | None = None) -> int:
    """The ``calibench`` command.

    Parameters
    ----------
    argv : list of str, optional
        The arguments after the program's name (default ``sys.argv[1:]``).

    Returns
    -------
    int
        The exit status (docs/formats.md): 0 ok, 1 a check failed, 2 bad input (one line on stderr),
        3 an internal error (the traceback in OUT/error.log), 130 interrupted.
    """
    os.environ.setdefault(
        "MUJOCO_GL", "egl"
    )  # before MuJoCo's first import: renders without a display
    _said_in_any_encoding()
    try:
        args = build_parser().parse_args(argv)
    except SystemExit as e:  # usage errors (status 2) and --help (0), as a return value
        return e.code if isinstance(e.code, int) else EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print("calibench: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    created: list[Path | None] = []
    held: list[claims.Claim] = []  # the folders this command claimed, released at its end
    old_term = _terminate_as_interrupt()
    # a library's warnings (numpy's) said after a command that ends with its results; an end said
    # in one line (bad input, interrupted, a defect) is that line alone
    caught = warnings.catch_warnings(record=True)
    noted = caught.__enter__()
    warnings.simplefilter("default")
    try:
        from calibench.scenarios.config import check_mujoco_gl

        check_mujoco_gl()  # before MuJoCo's first import, which a backend it lacks would fail
        _default_out(args)
        if hasattr(args, "out"):
            folders.inputs_outside(args)
        # the folders a command writes, checked before any work (made, and removed again if
        # the command ends in bad input and they are still empty)
        created.append(folders.writable_folder(getattr(args, "out", None)))
        created.append(folders.writable_folder(getattr(args, "save_images", None), "--save-images"))
        folders.views_folder_free(getattr(args, "save_images", None))
        _claim(args, held)
        verb = {
            "run": verbs.run,
            "fit": verbs.fit,
            "camera": verbs.camera,
            "montecarlo": verbs.montecarlo,
            "discover": verbs.discover,
            "iso230": standards.iso230,
            "acceptance": standards.acceptance,
            "uncertainty": standards.uncertainty,
        }[args.command]
        with for_command(args):  # its one bar, or a line every 30 s off a terminal (stderr)
            return verb(args)
    except BrokenPipeError:  # the reader went away (| head): nothing to say
        sys.stderr.close()
        return EXIT_OK
    except KeyboardInterrupt:
        kept = (
            "; finished trials are kept, rerun the same command to resume"
            if args.command in ("montecarlo", "uncertainty")
            else ""
        )
        print(f"calibench: interrupted{kept}", file=sys.stderr)
        noted.clear()
        return EXIT_INTERRUPTED
    except Exception as e:  # noqa: BLE001 - bad input is reported in one line
        from calibench.errors import BadInput

        said = _said_as_bad_input(e)
        if said is not None:
            e = BadInput(said)
        noted.clear()
        if isinstance(e, BadInput):
            print(f"calibench: {one_line(str(e))}", file=sys.stderr)
            claims.release(held)
            for made in created:
                if made is not None and made.is_dir() and not any(made.iterdir()):
                    made.rmdir()
            return EXIT_BAD_INPUT
        return _internal_error(e, getattr(args, "out", None))
    finally:
        claims.release(held)  # whatever the end: what --force set aside is gone, or put back
        if old_term is not None:
            signal.signal(signal.SIGTERM, old_term)
        caught.__exit__(None, None, None)
        for w in noted:
            warnings.showwarning(w.message, w.category, w.filename, w.lineno)


def command() -> None:
    """The ``calibench`` executable (and ``python -m calibench.scenarios.cli``): :func:`main`, its
    status the process's.

    The process ends without the interpreter's teardown: once the exit's own work is done (the
    study's workers joined, rerun's and multiprocessing's exit handlers run, stdout and stderr
    flushed), freeing every loaded module's objects one by one (rerun, pyarrow, scipy, MuJoCo) is
    0.2 s that a user waits for nothing. Every file calibench writes is closed by then (each is
    written in a ``with`` block, a recording by ``rrlog.close``). Under a tracer or a profiler
    (coverage, cProfile), whose exit handlers were registered before this one and write their
    data after it, the process exits as usual.
    """
    status: list[int] = []
    if sys.gettrace() is None and sys.getprofile() is None and "coverage" not in sys.modules:
        atexit.register(_end_now, status)  # registered first, so run last of the exit handlers
    status.append(main())
    sys.exit(status[0])


def _end_now(status: list[int]) -> None:
    """The last exit handler: stdout and stderr flushed, the process ended with ``status``."""
    if not status:  # main() did not return (an exception of Python's own): the usual exit
        return
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):  # a reader gone (| head), a stream closed: nothing to say
            pass
    os._exit(status[0])


def _raise_interrupt(signum, frame):
    raise KeyboardInterrupt


def _terminate_as_interrupt():
    """SIGTERM (what timeout, systemd and docker send) handled as Ctrl-C: one line, a study's
    journal kept, its workers stopped. Returns the previous handler (None off the main thread,
    where no handler can be set)."""
    if threading.current_thread() is not threading.main_thread():
        return None
    return signal.signal(signal.SIGTERM, _raise_interrupt)


def _default_out(args) -> None:
    """--out's default: the command's own folder (``run all``: one per scenario under
    ./calibench-out)."""
    if not hasattr(args, "out") or args.out is not None:
        return
    scenario = getattr(args, "scenario", None)
    if args.command == "run" and scenario == "all":
        args.out = Path("calibench-out")
    else:
        args.out = folders.default_out(args.command, scenario)


def _claim(args, held: list) -> None:
    """The folder made this command's, its claim put in ``held`` (``run all`` claims and releases
    each scenario's in turn, :func:`verbs.run`)."""
    if not hasattr(args, "out") or (args.command == "run" and args.scenario == "all"):
        return
    claims.claim(args.out, args.command, getattr(args, "scenario", None), args.force, held)


def _said_as_bad_input(e: Exception) -> str | None:
    """The line for errors that are the user's to fix, not calibench's: a full disk, a symbolic
    link loop (Python 3.11's ``Path.resolve`` raises RuntimeError for it), a file nested too deep
    to read (RecursionError: a TOML of thousands of nested tables)."""
    kept = "nothing half-written is left, the folder's former results are kept; a study resumes"
    if isinstance(e, OSError) and e.errno in (errno.ENOSPC, errno.EDQUOT):
        where = f" writing {e.filename}" if e.filename else ""
        return f"the disk is full{where}: free some space and rerun ({kept})"
    if isinstance(e, OSError) and e.errno == errno.EFBIG:
        where = f" writing {e.filename}" if e.filename else ""
        return (
            f"a file grew past this system's file-size limit{where} (ulimit -f): raise the limit "
            f"and rerun ({kept})"
        )
    if isinstance(e, OSError) and e.filename and e.errno in _UNWRITABLE:  # the folder's, not ours
        return f"{e.filename}: {e.strerror} (the file system's answer: check the folder's rights)"
    if isinstance(e, MemoryError):
        return (
            "out of memory: the input is too large for this machine's memory (or a memory limit "
            f"is set): give a smaller one, or more memory ({kept})"
        )
    if _dask_lost(e):
        return (
            "the Dask cluster went away mid-study (its scheduler stopped, or it lost its "
            "workers): finished trials are kept; rerun the same command to resume"
        )
    if isinstance(e, RecursionError):
        return (
            "an input file is nested too deep to read (thousands of levels): not a calibench file"
        )
    if isinstance(e, RuntimeError) and str(e).startswith("Symlink loop"):
        return f"{str(e).removeprefix('Symlink loop from ')}: a symbolic link loop, not a file"
    return None


def _internal_error(e: Exception, out: Path | None) -> int:
    """A defect of calibench: one line, the traceback in OUT/error.log (docs/formats.md's exit
    3)."""
    import traceback

    try:
        where = Path(out) if out is not None and not Path(out).is_file() else Path("calibench-out")
    except OSError:
        where = Path("calibench-out")
    from calibench import __version__
    from calibench.writing import write_text

    text = f"{folders.LOG_HEADER} (calibench {__version__})\n" + "".join(
        traceback.format_exception(e)
    )
    log = where / folders.LOGS[0]
    if folders.is_file(log) and not folders.is_calibench_log(log):  # the user's own: kept
        log = where / folders.LOGS[1]
    try:
        where.mkdir(parents=True, exist_ok=True)
        write_text(log, text)  # whole or not at all (an empty log on a full disk says nothing)
        said = f"the traceback is in {log}"
    except (OSError, ValueError) as w:  # a full disk, a link planted at the name (BadInput)
        said = f"the traceback could not be written ({getattr(w, 'strerror', None) or w})"
    first = str(e).splitlines()[0] if str(e).strip() else ""
    print(
        f"calibench: internal error ({type(e).__name__}: {one_line(first)}); this is a "
        f"defect of calibench, please report it; {one_line(said)}",
        file=sys.stderr,
    )
    return EXIT_INTERNAL


# a file that could not be written or read for the file system's reasons (a folder made read-only
# meanwhile, a failing disk)
_UNWRITABLE = (errno.EACCES, errno.EPERM, errno.EROFS, errno.EIO, errno.ENAMETOOLONG)


def _dask_lost(e: BaseException) -> bool:
    """Whether ``e`` is a Dask cluster lost mid-study (its scheduler killed: a cancelled future,
    a closed connection), an end of the environment's, not a defect."""
    import concurrent.futures as cf

    if "distributed" not in sys.modules:
        return False
    names = {type(e).__name__, *(t.__name__ for t in type(e).__mro__)}
    lost = {"CancelledError", "CommClosedError", "FutureCancelledError", "KilledWorker"}
    return isinstance(e, cf.CancelledError) or bool(names & lost)


def _said_in_any_encoding() -> None:
    """stdout and stderr write what their encoding cannot hold as escapes (PYTHONIOENCODING=ascii
    and a folder's name in another script) instead of failing the command at its last line."""
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.reconfigure(errors="backslashreplace")  # type: ignore[union-attr]
        except (AttributeError, ValueError, OSError):  # a stream replaced (a test's capture)
            pass
