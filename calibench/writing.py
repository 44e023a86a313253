"""How calibench writes a file: whole or not at all, and never through a link.

Every output is written to a temporary file beside its name (same folder, so the rename cannot
cross file systems), flushed to the disk (``fsync``) and renamed over the name (``os.replace``):
a full disk, a file-size limit or a kill midway leaves the former file as it was, never a torn
one. A symbolic link at the name is replaced by the rename, never written through (a user's file
elsewhere stays as it was); whose the name is, a link there included, the command line's claim
on the folder decides before anything is written (``scenarios/cli/claims.py``). A temporary file
left by a command killed outright is known by its name (:func:`is_temporary`): the next command
in that folder removes it. Needs nothing but Python.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path

# a temporary file's name: PREFIX + "<random>." + the output's name (its suffix kept: a writer
# that picks its format by the suffix, a figure's or an image's, writes the right one)
PREFIX = ".calibench-tmp."
_UMASK = os.umask(0o022)  # read once (it can only be read by setting it), and put back
os.umask(_UMASK)


def is_temporary(name: str) -> bool:
    """Whether ``name`` is a temporary file of :func:`replaced`'s (one a killed command left)."""
    return name.startswith(PREFIX)


@contextlib.contextmanager
def replaced(path: str | Path) -> Iterator[Path]:
    """A temporary file beside ``path`` to write to (by any writer that takes a path), flushed and
    renamed over ``path`` when the block ends; removed instead if the block fails.

    Parameters
    ----------
    path : str or Path
        The output's name.

    Yields
    ------
    Path
        The temporary file (created empty, its name calibench's own: :func:`is_temporary`).

    Raises
    ------
    OSError
        The file could not be written (a full disk, a size limit), said of ``path``.
    """
    path = Path(path)
    fd, name = tempfile.mkstemp(prefix=PREFIX, suffix=f".{path.name[-100:]}", dir=path.parent)
    try:  # mkstemp's 0600 would hide a result from the user's group: the mode open() gives
        os.fchmod(fd, 0o666 & ~_UMASK)
    finally:
        os.close(fd)
    tmp = Path(name)
    try:
        yield tmp
        _flush(tmp)
        os.replace(tmp, path)  # a link at the name is replaced, not followed
    except OSError as e:  # a full disk, a size limit: said of the output, not its temporary
        raise OSError(e.errno, e.strerror, str(path)) from None
    finally:
        tmp.unlink(missing_ok=True)
    _flush_folder(path.parent)


@contextlib.contextmanager
def replaced_in(folder: str | Path) -> Iterator[Path]:
    """A temporary folder inside ``folder`` for a writer that names its own files (a figure's
    ``out_dir / FIGURE``): each file it holds when the block ends is flushed and renamed into
    ``folder`` (as :func:`replaced`); the temporary folder goes whatever the end.

    Parameters
    ----------
    folder : str or Path
        Where the files belong.

    Yields
    ------
    Path
        The temporary folder (its name calibench's own: :func:`is_temporary`).
    """
    folder = Path(folder)
    tmp = Path(tempfile.mkdtemp(prefix=PREFIX, suffix=".d", dir=folder))
    try:
        yield tmp
        for made in sorted(tmp.iterdir()):
            path = folder / made.name
            try:
                _flush(made)
                os.replace(made, path)
            except OSError as e:
                raise OSError(e.errno, e.strerror, str(path)) from None
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    _flush_folder(folder)


def write_bytes(path: str | Path, data: bytes) -> None:
    """Write ``data`` as ``path``, whole or not at all (:func:`replaced`)."""
    with replaced(path) as tmp:
        with open(tmp, "wb") as f:
            f.write(data)


def write_text(path: str | Path, text: str) -> None:
    """Write ``text`` (UTF-8) as ``path``, whole or not at all (:func:`replaced`)."""
    write_bytes(path, text.encode("utf-8"))


def _flush(path: Path) -> None:
    """The file's data on the disk before its name points at it (a crash of the machine after
    the rename would otherwise leave an empty file under the name)."""
    fd = os.open(path, os.O_RDONLY | os.O_NOFOLLOW)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _flush_folder(folder: Path) -> None:
    """The rename itself on the disk; a file system that cannot sync a folder is left to its
    own schedule."""
    try:
        fd = os.open(folder, os.O_RDONLY | os.O_DIRECTORY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)
