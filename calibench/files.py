"""Whether paths name one file: the checks a command makes of the files it is given.

A photo or a recording given twice (under two names, or through a link) would count twice; an
output that is one of the inputs would overwrite it. Needs nothing but Python (``calibench
camera`` imports it without the recordings' readers).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path


def same_file(a: str | Path, b: str | Path) -> bool:
    """Whether two paths name one file (through links too).

    Parameters
    ----------
    a, b : str or Path
        The two paths; one that does not exist yet is the other only if it resolves to it.

    Returns
    -------
    bool
        True when both name the same file.
    """
    try:
        return Path(a).resolve() == Path(b).resolve() or Path(a).samefile(b)
    except OSError:
        return False


def first_repeat(paths: Sequence[str | Path]) -> Path | None:
    """The first of ``paths`` that names a file named before it, through links too.

    Each file's identity (device, inode) is taken once, not each pair's paths resolved (27 ms
    for a dozen photos). A path that cannot be read is nobody's repeat: its reader says why.

    Parameters
    ----------
    paths : sequence of str or Path
        The files, in the order given.

    Returns
    -------
    Path or None
        The first repeat, None when each file is named once.
    """
    seen = set()
    for p in map(Path, paths):
        try:
            st = p.stat()
        except OSError:
            continue
        if (st.st_dev, st.st_ino) in seen:
            return p
        seen.add((st.st_dev, st.st_ino))
    return None
