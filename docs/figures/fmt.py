"""Formatting for the blocks: spans, ranges and lists in words, markdown tables."""

from __future__ import annotations


def mean(xs) -> float:
    """The arithmetic mean of a non-empty sequence."""
    return sum(xs) / len(xs)


def span(values, fmt: str = ".3f", sep: str = "-") -> str:
    """'lo-hi' of the values (one value if they print the same)."""
    lo, hi = format(min(values), fmt), format(max(values), fmt)
    return lo if lo == hi else f"{lo}{sep}{hi}"


def ranges(pairs) -> str:
    """[[37, 76], [78, 78], [80, 80]] as '37-76, 78 and 80'."""
    parts = [str(a) if a == b else f"{a}-{b}" for a, b in pairs]
    return parts[0] if len(parts) == 1 else ", ".join(parts[:-1]) + " and " + parts[-1]


def words(items) -> str:
    """'a', 'a and b', 'a, b and c'."""
    items = list(items)
    return items[0] if len(items) == 1 else ", ".join(items[:-1]) + " and " + items[-1]


def rows_words(rows: list[int]) -> str:
    """'row 7' or 'rows 3, 5 and 7' (sorted)."""
    return ("row " if len(rows) == 1 else "rows ") + words([str(r) for r in sorted(rows)])


def sci(x: float) -> str:
    """A round number in short scientific notation: 3e5, 6e4 (no '+', no leading zero)."""
    mant, _, exp = f"{x:.0e}".partition("e")
    return f"{mant}e{int(exp)}"


def percent(fraction: float) -> str:
    """A fraction as a whole percentage with a space before the sign: 0.3 -> '30 %'."""
    return f"{100 * fraction:.0f} %"


def table(header: list[str], rows: list[list[str]]) -> str:
    """A markdown table."""

    def row(cells):
        return "|" + "|".join(f" {c} " if c else " " for c in cells) + "|"

    return "\n".join([row(header), "|" + "---|" * len(header)] + [row(r) for r in rows])


def bold_least(cells: list[float], fmt: str) -> list[str]:
    """The values formatted, the least in bold."""
    best = min(cells)
    return [f"**{v:{fmt}}**" if v == best else f"{v:{fmt}}" for v in cells]
