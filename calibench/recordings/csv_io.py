"""The CSV every recording format shares: one reader with its checks, one writer.

The reader turns any defect of a file (unreadable, not UTF-8, separated by semicolons, a column
missing, named twice or by another usual name of one the format reads, a row with a value too
many, a cell that is not a number or not finite, a temperature or load out of range, a pass id
that is not whole) into one ``RecordingError`` naming the file and, where it can, the line.
"""

from __future__ import annotations

import csv
import re
from collections.abc import Iterator
from pathlib import Path

import numpy as np

from calibench.errors import BadInput


class RecordingError(BadInput):
    """A recording that cannot be used as it is (missing column, NaN, unreadable file)."""


# Other names users give the formats' columns, each as unambiguous as the column's own (its unit
# or its meaning in the name): a file that names one so would have it ignored (an optional
# column) or missing (a required one), and say nothing of it. A bare ``time`` or ``temperature``
# is not here: it may be a clock's text or degrees Fahrenheit, and is ignored as any column is.
ALIASES = {
    "t_s": ("time_s", "t_sec", "time_sec", "seconds"),
    "temp_c": ("temperature_c", "temp_degc", "temperature_degc"),
    "dir_x": ("direction_x", "x_direction", "x_dir"),
    "dir_y": ("direction_y", "y_direction", "y_dir"),
    "run": ("run_id", "pass_id"),
    "x_std_mm": ("x_sigma_mm", "sigma_x_mm", "std_x_mm"),
    "y_std_mm": ("y_sigma_mm", "sigma_y_mm", "std_y_mm"),
    "z_std_mm": ("z_sigma_mm", "sigma_z_mm", "std_z_mm"),
}
UNITS = {"_s": "seconds", "_c": "deg C", "_mm": "mm", "_deg": "degrees", "_um": "um"}


def _key(name: str) -> str:
    """A column name as compared for a near miss: lower case, letters and digits only."""
    return re.sub(r"[^a-z0-9]", "", name.lower())


def _near_miss(header: list[str], known: tuple) -> tuple[str, str] | None:
    """The first column of ``header`` that is not one of ``known`` but is one of them in another
    case or spelling (``Temp_C``, ``dirx``) or by another usual name (``temperature_c``), and the
    absent column it stands for; None when there is none."""
    wanted = [k for k in known if k not in header]
    for h in header:
        if not h or h in known:
            continue
        for k in wanted:
            if _key(h) == _key(k) or _key(h) in {_key(a) for a in ALIASES.get(k, ())}:
                return h, k
    return None


# characters: the longest line a recording's CSV may have. A row of 20 numbers is about 500 and a
# header of 50 named columns under 2,000; a line is read at most this far before it is judged,
# so a file without line ends (a header, one row and 50 million commas; /dev/zero) is refused
# in bounded memory instead of read whole
MAX_LINE_CHARS = 100_000


def bounded_lines(f, path: Path) -> Iterator[str]:
    """The lines of the text file ``f`` (opened with ``newline=""``), each read at most
    :data:`MAX_LINE_CHARS` characters far: a longer one, or one holding NUL characters (UTF-16
    text, or not text at all), refused."""
    at = 0
    while True:
        line = f.readline(MAX_LINE_CHARS + 1)
        if not line:
            return
        at += 1
        if len(line) > MAX_LINE_CHARS:
            raise RecordingError(
                f"{path} line {at}: over {MAX_LINE_CHARS:,} characters without a line end: not a "
                "recording's row (a row of 20 numbers is about 500)"
            )
        if "\x00" in line:
            raise RecordingError(_nul_message(path, line))
        yield line


def _nul_message(path: Path, line: str) -> str:
    """What a line holding NUL characters says of its file: UTF-16 where every other character
    is one (an ASCII text saved as UTF-16 without its byte-order mark), else not text."""
    body = line.rstrip("\r\n")
    if len(body) >= 2 and ("\x00" not in body[0::2] or "\x00" not in body[1::2]):
        if set(body[1::2]) <= {"\x00"} or set(body[0::2]) <= {"\x00"}:
            return (
                f"{path} is not UTF-8 text: it looks like UTF-16 (every other byte zero): save "
                "it as UTF-8 CSV"
            )
    return f"{path} is not UTF-8 text: it holds NUL characters (a binary file, not a CSV?)"


def _encoding_guess(path: Path) -> str:
    """What a file that is not UTF-8 may be, in words, from its byte-order mark."""
    try:
        with open(path, "rb") as f:
            head = f.read(2)
    except OSError:
        head = b""
    if head in (b"\xff\xfe", b"\xfe\xff"):
        return "UTF-16, by its byte-order mark"
    return "Latin-1, or not a CSV at all?"


def read_header(path: Path) -> list[str]:
    """The CSV's first row (stripped names), read through :func:`bounded_lines`; [] where the
    file cannot be read (:func:`read_columns` then says what is wrong)."""
    try:
        with open(path, newline="", encoding="utf-8-sig") as f:
            return [h.strip() for h in next(csv.reader(bounded_lines(f, path)), [])]
    except (OSError, UnicodeDecodeError, csv.Error, RecordingError):
        return []


def _named_alike(header: list[str], known: tuple) -> tuple[str, str] | None:
    """A column the format reads and another of ``header`` that names it too (``X_CMD_MM``
    beside ``x_cmd_mm``, ``temperature_c`` beside ``temp_c``), or None: one of the two would be
    read and the other ignored without a word."""
    for k in known:
        if k not in header:
            continue
        keys = {_key(k)} | {_key(a) for a in ALIASES.get(k, ())}
        other = next((h for h in header if h and h != k and _key(h) in keys), None)
        if other is not None:
            return k, other
    return None


def _rows(reader, path: Path, max_rows: int | None, width: list[int]) -> list[list[str]]:
    """The CSV's rows, refused as soon as it holds more than ``max_rows`` data rows (read on
    only to count them, the whole file would be in memory first). A row's empty cells beyond
    the header's (``width[0]``, set from the first row) are dropped as it is read: harmless,
    and a line of commas would be a list of as many cells."""
    rows: list[list[str]] = []
    data = 0
    for r in reader:
        if not rows:
            width.append(len(r))
        elif len(r) > width[0]:
            while len(r) > width[0] and not r[-1].strip():
                r.pop()
        rows.append(r)
        if len(rows) > 1 and any(cell.strip() for cell in r):
            data += 1
            if max_rows is not None and data > max_rows:
                raise RecordingError(
                    f"{path}: more than {max_rows} rows; this command takes at most {max_rows}: "
                    "decimate the recording or split it"
                )
    return rows


def read_columns(
    path: str | Path, required: tuple, optional: tuple, max_rows: int | None = None
) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """Numeric columns of a CSV by name, with each data row's line in the file.

    Parameters
    ----------
    path : str or Path
        The CSV file: a header row of column names, then one row of numbers per sample (UTF-8,
        with or without a byte-order mark; CRLF or LF line ends; quoted cells allowed).
    required : tuple of str
        Columns that must be present.
    optional : tuple of str
        Columns read when present.
    max_rows : int or None
        Refuse a file with more data rows than this, before converting it.

    Returns
    -------
    columns : dict of str to ndarray
        Each present required or optional column, (n,) float, all finite.
    line : ndarray
        (n,) int, each data row's line in the file (the header is line 1; blank lines are skipped,
        not renumbered).

    Raises
    ------
    RecordingError
        One clear message for any defect, naming the file and the line where there is one.
    """
    path = Path(path)
    rows = read_rows(path, max_rows)
    header = checked_header(path, rows, required, optional)
    lines, body = data_rows(path, rows, header, max_rows)
    fields = {
        name: numeric_column(path, name, header.index(name), lines, body)
        for name in required + optional
        if name in header
    }
    line = np.array(lines)
    _check_common(path, fields, line)
    return fields, line


def read_rows(path: Path, max_rows: int | None) -> list[list[str]]:
    """The CSV's rows of cells, the header's first (UTF-8 with or without a byte-order mark);
    a file that cannot be read as such, or holds more than ``max_rows`` data rows, refused."""
    try:
        with open(path, newline="", encoding="utf-8-sig") as f:
            rows = _rows(csv.reader(bounded_lines(f, path)), path, max_rows, [])
    except IsADirectoryError:
        raise RecordingError(f"{path} is a folder, not a CSV file") from None
    except OSError as e:
        raise RecordingError(f"cannot read {path}: {e.strerror}") from None
    except UnicodeDecodeError:
        raise RecordingError(
            f"{path} is not UTF-8 text ({_encoding_guess(path)}): save it as UTF-8 CSV"
        ) from None
    except csv.Error as e:
        raise RecordingError(f"{path} is not a CSV file ({e})") from None
    if not rows or not rows[0]:
        raise RecordingError(f"{path} is empty")
    return rows


def checked_header(
    path: Path, rows: list[list[str]], required: tuple, optional: tuple
) -> list[str]:
    """The header's column names (stripped), refused where they are separated by semicolons,
    one is named twice, one is a near miss of a column the format reads (another case,
    spelling or usual name: :func:`_near_miss`), or a ``required`` one is missing."""
    header = [h.strip() for h in rows[0]]
    if len(header) == 1 and ";" in header[0]:
        raise RecordingError(
            f"{path} is separated by semicolons (a spreadsheet's export with decimal commas?): "
            "the format wants commas between values and points in numbers"
        )
    twice = sorted({h for h in header if h and header.count(h) > 1})
    if twice:
        raise RecordingError(
            f"{path}: column(s) {', '.join(twice)} named twice: which one is meant cannot be told"
        )
    alike = _named_alike(header, required + optional)
    if alike is not None:
        raise RecordingError(
            f"{path}: columns {alike[0]} and {alike[1]} both name {alike[0]} (another case, "
            "spelling or usual name): which one is meant cannot be told; drop or rename one"
        )
    near = _near_miss(header, required + optional)
    if near is not None:
        fate = "missing" if near[1] in required else "ignored"
        unit = next((u for end, u in UNITS.items() if near[1].endswith(end)), None)
        raise RecordingError(
            f"{path}: column {near[0]!r} is not one the format knows, so {near[1]} would be "
            f"{fate}: if it is {near[1]}, name it so"
            + (f" (in {unit})" if unit else "")
            + "; if not, rename or drop it"
        )
    missing = [c for c in required if c not in header]
    if missing:
        raise RecordingError(f"{path}: missing column(s) {', '.join(missing)}")
    return header


def data_rows(
    path: Path, rows: list[list[str]], header: list[str], max_rows: int | None
) -> tuple[list[int], list[list[str]]]:
    """The data rows (blank ones skipped) and each one's line in the file (the header is line 1;
    blank lines are skipped, not renumbered); refused when there are none, more than
    ``max_rows``, or a row has a value beyond the header's last column."""
    lines = [i + 2 for i, r in enumerate(rows[1:]) if any(cell.strip() for cell in r)]
    body = [rows[i - 1] for i in lines]
    if not body:
        raise RecordingError(f"{path}: no data rows")
    # a value beyond the header's last column shifts every value after it (a decimal comma, a
    # stray separator): the columns can no longer be trusted (trailing empty cells are harmless)
    for i, r in enumerate(rows[1:]):
        if len(r) > len(header) and any(cell.strip() for cell in r[len(header) :]):
            raise RecordingError(
                f"{path} line {i + 2}: {len(r)} values, the header names {len(header)} columns "
                "(a decimal comma, or a separator too many?)"
            )
    if max_rows is not None and len(body) > max_rows:
        raise RecordingError(
            f"{path}: {len(body)} rows; this command takes at most {max_rows}: decimate the "
            "recording or split it"
        )
    return lines, body


def numeric_column(
    path: Path, name: str, j: int, lines: list[int], body: list[list[str]]
) -> np.ndarray:
    """The ``j``-th cells of the data rows ``body`` as the column ``name``, (n,) float, all
    finite; a cell that is not a number (or is missing) or not finite refused at its line."""
    try:  # the whole column at once; the loop below only finds the bad cell
        cells = [r[j] for r in body]
        values = np.array(cells, dtype=float)
        if any("_" in c for c in cells):  # Python's float reads 1_000: a CSV number has none
            raise ValueError
    except (IndexError, ValueError):
        for at, r in zip(lines, body):
            cell = r[j] if j < len(r) else ""
            try:
                if "_" in cell:
                    raise ValueError
                float(cell)
            except ValueError:
                raise RecordingError(
                    f"{path} line {at}: column {name} is {cell!r}, not a number"
                ) from None
        raise
    bad = ~np.isfinite(values)
    if bad.any():
        raise RecordingError(
            f"{path} line {lines[int(np.argmax(bad))]}: column {name} is not finite"
        )
    return values


def _check_common(path, cols: dict, line: np.ndarray) -> None:
    """The optional columns every format shares: a machine's temperature, a load, a pass id.
    ``line`` (n,): each row's line in the file."""
    for name, lo, hi, what in (
        ("temp_c", -100.0, 200.0, "not a machine's temperature in deg C (-100 to 200)"),
        ("load_n", -1e6, 1e6, "over 100 t: a wrong unit or a corrupt value"),
    ):
        v = cols.get(name)
        if v is not None and np.any((v < lo) | (v > hi)):
            i = int(np.argmax((v < lo) | (v > hi)))
            raise RecordingError(f"{path} line {line[i]}: {name} is {v[i]:.3g}: {what}")
    run = cols.get("run")
    if run is not None and np.any(run != np.round(run)):
        i = int(np.argmax(run != np.round(run)))
        raise RecordingError(
            f"{path} line {line[i]}: run is {run[i]:g}; a pass id is a whole number"
        )


def write_csv(path, cols: list[str], data: list[np.ndarray]) -> None:
    """Write columns to a CSV with a header row, ten significant digits a value.

    Parameters
    ----------
    path : str or Path
        The file to write (replaced).
    cols : list of str
        The header's column names, in order.
    data : list of ndarray
        (n,) or (n, k) arrays, stacked side by side into ``len(cols)`` columns.
    """
    np.savetxt(
        path, np.column_stack(data), delimiter=",", header=",".join(cols), comments="", fmt="%.10g"
    )
