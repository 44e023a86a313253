"""The house rules of DESIGN.md that a reader cannot see from one file: the rooms' imports, the
size of a file, and private names kept private. Each fails with the offending places listed."""

import ast
import subprocess
import sys

from tests.conftest import REPO

MAX_LINES = 500
MAX_FUNCTION_LINES = 120
PRODUCT_ROOMS = ("calibench/", "estimators/", "scenarios/", "scenes/", "sim/")


def _python_files() -> list[str]:
    out = subprocess.run(
        ["git", "ls-files", "--cached", "--others", "--exclude-standard", "*.py"],
        cwd=REPO,
        capture_output=True,
        text=True,
        check=True,
    ).stdout.split()
    return [f for f in out if (REPO / f).exists()]


def _imports(path: str) -> list[tuple[int, str, list[str]]]:
    """(line, module, names) of every import of ``path``, ``import m`` as (line, m, [])."""
    tree = ast.parse((REPO / path).read_text())
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            out.append((node.lineno, node.module, [a.name for a in node.names]))
        elif isinstance(node, ast.Import):
            out += [(node.lineno, a.name, []) for a in node.names]
    return out


def test_no_source_file_is_over_500_lines():
    big = {
        f: n for f in _python_files() if (n := len((REPO / f).read_text().splitlines())) > MAX_LINES
    }
    assert not big, big


def test_no_product_function_is_over_120_lines():
    """A function a reader can hold in view: its definition to its last line, docstring
    included."""
    long = [
        f"{f}:{node.lineno} {node.name} ({node.end_lineno - node.lineno + 1} lines)"
        for f in _python_files()
        if f.startswith(PRODUCT_ROOMS)
        for node in ast.walk(ast.parse((REPO / f).read_text()))
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef))
        and node.end_lineno - node.lineno + 1 > MAX_FUNCTION_LINES
    ]
    assert not long, long


def test_no_private_name_is_imported_from_another_module():
    bad = [
        f"{f}:{line}: from {module} import {name}"
        for f in _python_files()
        for line, module, names in _imports(f)
        if module.startswith(("calibench", "tests"))
        for name in names
        if name.startswith("_") and not (name.startswith("__") and name.endswith("__"))
    ]
    assert not bad, bad


def test_estimators_import_only_numpy_scipy_cv2_and_themselves():
    """Truth never leaks into an estimator: besides the standard library, only numpy, scipy,
    cv2 and the estimators themselves."""
    allowed = ("numpy", "scipy", "cv2", "calibench.estimators")
    bad = [
        f"{f}:{line}: {module}"
        for f in _python_files()
        if f.startswith("estimators/")
        for line, module, _ in _imports(f)
        if module.split(".")[0] not in sys.stdlib_module_names
        and module.split(".")[0] not in ("numpy", "scipy", "cv2")
        and not module.startswith(allowed)
    ]
    assert not bad, bad


def test_sim_never_imports_the_estimators_nor_the_scenarios():
    bad = [
        f"{f}:{line}: {module}"
        for f in _python_files()
        if f.startswith("sim/")
        for line, module, _ in _imports(f)
        if module.startswith(("calibench.estimators", "calibench.scenarios"))
    ]
    assert not bad, bad


def test_every_test_the_slow_list_names_exists():
    """tests/slow_tests.txt names tests that exist: a renamed test would otherwise fall back into
    ``make test`` unseen, and a stale line would hide nothing."""
    from tests.conftest import slow_tests

    for node in slow_tests():
        path, _, name = node.partition("::")
        function = name.partition("[")[0]
        assert (REPO / path).is_file(), node
        assert f"def {function}(" in (REPO / path).read_text(), node


MAX_NAME_FILES = 4


def test_an_instruments_name_is_spelled_in_at_most_four_product_files():
    """A scenario's name is a string in its registry line, its scene, its concealed recordings
    and at most one more place; every other module asks the registry or imports its ``NAME``.
    More means a new instrument (or a renamed one) is again a hunt through the tree."""
    import re

    from calibench.scenarios import registry

    sources = {f: (REPO / f).read_text() for f in _python_files() if f.startswith(PRODUCT_ROOMS)}
    spread = {}
    for name in registry.NAMES:
        quoted = re.compile(rf"[\"']{re.escape(name)}[\"':>]")
        files = sorted(f for f, text in sources.items() if quoted.search(text))
        if len(files) > MAX_NAME_FILES:
            spread[name] = files
    assert not spread, spread
