"""The README's numbers agree with the code (issue 15): ``python -m docs.figures --check``
regenerates every generated block of the README (the render runs, the Monte-Carlo studies, the
concealed-effect suite and the null sweep, the UR10 fits and discoveries, the analyses of their
residuals) and compares every number with the README's. Each group of blocks (a block module,
whose blocks share their runs) is a test of its own, run in a process of its own, so that
``make test-slow``'s workers spread them over the cores.

The README (and its docs/*.md pages) is the expectation and the code the truth: nothing here
holds a figure. Blocks left to ``make figures``: performance, memory and run-times
(machine timings and peak memory, which it rewrites and nothing compares), discover-coverage
(640 discoveries over every core, under an hour on 2: ``make figures-check
FIGURES=discover-coverage``) and
ur10-sessions-floor (four more leave-one-session-out folds, eleven minutes:
``make figures-check FIGURES=ur10-sessions-floor``), and the two longest UR10 tables, ur10-all-four
(five fits of all four series, discovery among them: fourteen minutes) and ur10-sessions-table
(four leave-one-session-out folds twice: eight minutes), which would keep CI past its 40 minutes
(``make figures-check FIGURES="ur10-all-four ur10-sessions-table"``), and discover-nulls (120
fresh null recordings judged at three or four floors, seven minutes: the suites'
nulls keep the house floor's false-claim rate in CI), discover-simulated (the third suite's 36
discoveries, eleven minutes: tests/scenarios/test_discover_simulated.py runs its cases) and
discover-mechanism-coverage (120 discoveries, 25 minutes on 2 cores, a minute on the lent
16-core machine). Two are checked by the
tests that run their computation anyway, on that one run
(``docs.figures.engine.readme_disagrees``): discover-suite (tests/scenarios/test_discover_suite.py)
and discover-unwritten (tests/scenarios/test_discover_unwritten.py).
"""

import subprocess
import sys
from pathlib import Path

import pytest

FIGURES = "docs.figures"  # the package, run as ``python -m docs.figures`` from the repository
REPO = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def figures():
    """The block engine, every block registered (the package imports them)."""
    from docs.figures import engine

    return engine


def test_every_block_has_its_markers_and_its_generator(figures):
    """Every block sits once in the README or one of its docs/*.md pages."""
    in_pages = figures.block_pages()
    assert sorted(in_pages) == sorted(figures.BLOCKS)


def test_the_docstring_names_every_block_the_test_leaves_out(figures):
    left = [name for name, b in figures.BLOCKS.items() if not b.ci]
    assert left and all(name in __doc__ for name in left), [n for n in left if n not in __doc__]


def test_numbers_are_read_as_printed(figures):
    got = [
        tok
        for _, tok in figures.numbers(
            "B 1.0-1.8 mm, ur10_C row 2,773; fx -0.34 %, 3e-10 um, joint-6 +- 0.05"
        )
    ]
    assert got == ["1.0", "1.8", "2,773", "-0.34", "3e-10", "6", "0.05"]


def test_a_changed_digit_is_a_disagreement_and_a_band_is_not(figures):
    exact = figures.Block("x", lambda: "", 0, True)
    assert figures.disagreements(exact, "RMS 0.0083 mm, 12 dropped", "RMS 0.0084 mm, 12 dropped")
    assert figures.disagreements(exact, "RMS 0.0083 mm", "RMS 0.0083 mm and 2 more")
    assert not figures.disagreements(exact, "RMS 0.50 mm", "RMS 0.5 mm")
    band = figures.Block("x", lambda: "", 0, True, rel=0.01)
    assert not figures.disagreements(band, "coverage 0.948", "coverage 0.951")
    assert figures.disagreements(band, "coverage 0.948", "coverage 0.960")


def test_a_rewrite_keeps_the_markers_and_reads_back(figures):
    text = (
        "intro\n\n<!-- figures:t -->\nold 1\n<!-- /figures:t -->\n\n"
        "- item\n  <!-- figures:u -->\n  old 2\n"
        "  <!-- /figures:u -->\n"
    )
    new = figures.replace(text, {"t": "| a | 3 |", "u": "new 4 " + "word " * 30})
    assert figures.current(new, "t") == "| a | 3 |"
    assert figures.numbers(figures.current(new, "u"))[0][0] == 4
    assert all(len(line) <= figures.WIDTH for line in new.splitlines())
    assert figures.spans(new).keys() == {"t", "u"}


def figure_groups() -> list[tuple[str, ...]]:
    """The blocks the CI runs (``ci=True``) in groups, each checked by a process of its own so that
    pytest's workers (``-n``) spread them over the cores: one group per block module, whose blocks
    share their runs (``docs.figures.runner``'s caches), in the package's order."""
    from docs.figures import BLOCKS

    groups: dict[str, list[str]] = {}
    for name, b in BLOCKS.items():
        if b.ci:
            groups.setdefault(b.make.__module__.rsplit(".", 1)[-1], []).append(name)
    return [tuple(names) for names in groups.values()]


def figures_check_command(names) -> list[str]:
    """``python -m docs.figures --check NAME...``, to be run in the repository's root."""
    return [sys.executable, "-m", FIGURES, "--check", *names]


def test_the_groups_hold_every_ci_block_once(figures):
    named = [n for g in figure_groups() for n in g]
    assert sorted(named) == sorted(n for n, b in figures.BLOCKS.items() if b.ci)
    assert len(named) == len(set(named))


@pytest.mark.slow
@pytest.mark.parametrize("names", figure_groups(), ids=lambda g: g[0])
def test_the_readme_agrees_with_the_code(names, real_data):
    """The README's blocks of one group, regenerated in a process of their own and compared."""
    r = subprocess.run(figures_check_command(names), cwd=REPO, capture_output=True, text=True)
    assert r.returncode == 0, r.stdout + r.stderr


def test_the_command_line_lists_every_block_and_refuses_an_unknown_one(capsys):
    """``python -m docs.figures --list`` names every block in order; an unknown name exits 2."""
    from docs.figures import BLOCKS, main

    assert main(["--list"]) == 0
    listed = [line.split()[0] for line in capsys.readouterr().out.splitlines()]
    assert listed == list(BLOCKS)
    assert main(["--check", "no-such-block"]) == 2
