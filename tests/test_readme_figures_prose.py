"""Generated text holds no literal numbers: every number in a README block comes from a run, a
computation or a named constant (imported from the library where it lives there), never typed
into the prose. This reads the block modules of docs/figures (and the formatting they share) and
fails on a number in a string literal or in an f-string's literal parts, as the figures check
would read one (engine.numbers: '9x6' is a number, 'ur10_C.csv', 'q2' and 'coverage_95' are
names). Left alone: docstrings, format specs, the values of module-level named constants
(UPPER_CASE), and the few citations below."""

import ast

from tests.conftest import REPO

PACKAGE = REPO / "docs" / "figures"
NOT_BLOCKS = {"__init__.py", "__main__.py", "engine.py", "runner.py"}  # no generated prose

# substrings of prose that hold digits and are not figures, each with why
ALLOWED = {
    "Eq. 3-4": "the seed paper's equations, cited",
    "Eq. 5-9": "the seed paper's equations, cited",
    "Table 3": "the seed paper's table, cited",
    "mm^2": "a unit's exponent",
    "R^2": "the coefficient of determination's name",
}


def _skipped(tree: ast.Module) -> set[int]:
    """ids of the nodes whose strings are not prose: docstrings, format specs, named constants."""
    skip = set()
    for node in ast.walk(tree):
        body = getattr(node, "body", None)
        if isinstance(node, ast.Module | ast.FunctionDef | ast.ClassDef) and body:
            first = body[0]
            if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant):
                skip.add(id(first.value))
        if isinstance(node, ast.FormattedValue) and node.format_spec is not None:
            skip |= {id(n) for n in ast.walk(node.format_spec)}
    for stmt in tree.body:
        targets = stmt.targets if isinstance(stmt, ast.Assign) else []
        names = [n.id for t in targets for n in ast.walk(t) if isinstance(n, ast.Name)]
        if names and all(n.isupper() for n in names):
            skip |= {id(n) for n in ast.walk(stmt.value)}
    return skip


def literal_numbers(source: str, filename: str = "<source>") -> list[str]:
    """'file:line: the fragment' for each string literal (or f-string literal part) of
    ``source`` that holds a number the figures check would read."""
    from docs.figures.engine import numbers

    tree = ast.parse(source)
    skip = _skipped(tree)
    out = []
    for node in ast.walk(tree):
        if id(node) in skip or not isinstance(node, ast.Constant):
            continue
        if not isinstance(node.value, str):
            continue
        text = node.value
        for allowed in ALLOWED:
            text = text.replace(allowed, "")
        if numbers(text):
            out.append((node.lineno, f"{filename}:{node.lineno}: {node.value!r}"))
    return [hit for _, hit in sorted(out)]


def test_no_block_types_a_number_into_its_prose():
    found = [
        hit
        for path in sorted(PACKAGE.glob("*.py"))
        if path.name not in NOT_BLOCKS
        for hit in literal_numbers(path.read_text(), path.name)
    ]
    assert not found, "\n".join(found)


def test_the_scan_finds_a_typed_number_and_passes_names_specs_and_constants():
    source = '''
"""Docstring with 3 numbers, 4 and 5."""
LIMIT_MM = 0.5
PAPER = {"about": "60 um"}
def f(x):
    """Run on seed 0."""
    a = f"{x:.3f} mm after a move of more than 60 degrees"
    b = f"{x:+.0%} of ur10_C.csv, q2 and coverage_95 (Eq. 5-9)"
    c = "the board 9x6"
    return a + b + c
'''
    hits = literal_numbers(source)
    assert [h.split(": ", 1)[1] for h in hits] == [
        "' mm after a move of more than 60 degrees'",
        "'the board 9x6'",
    ]
