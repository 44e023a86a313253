"""The README's numbers agree with the code (issue 15): ``python -m docs.figures --check``
regenerates every generated block of the README (the render runs, the Monte-Carlo studies, the
concealed-effect suite and the null sweep, the UR10 fits and discoveries, the analyses of their
residuals) and compares every number with the README's. It runs in its own process beside the
rest of the suite (tests/conftest.py starts it at collection): about half an hour on 2 cores.

The README (and its docs/*.md pages) is the expectation and the code the truth: nothing here
holds a figure. Five blocks are left to ``make figures``: performance, memory and run-times
(machine timings and peak memory, which it rewrites and nothing compares), discover-coverage
(640 discoveries over every core, under an hour on 2: ``make figures-check
FIGURES=discover-coverage``) and
ur10-sessions-floor (four more leave-one-session-out folds, eleven minutes:
``make figures-check FIGURES=ur10-sessions-floor``).
"""

import sys

import pytest

FIGURES = "docs.figures"  # the package, run as ``python -m docs.figures`` from the repository


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


def figures_check_command() -> list[str]:
    """``python -m docs.figures --check`` over every block the CI runs (``ci=True``), to be run
    in the repository's root."""
    from docs.figures import BLOCKS

    return [sys.executable, "-m", FIGURES, "--check", *[n for n, b in BLOCKS.items() if b.ci]]


def test_the_readme_agrees_with_the_code(real_data, request):
    """Started beside the rest of the suite (tests/conftest.py), collected here."""
    from tests.conftest import figures_check_result

    code, printout = figures_check_result(request.config)
    assert code == 0, printout


def test_the_command_line_lists_every_block_and_refuses_an_unknown_one(capsys):
    """``python -m docs.figures --list`` names every block in order; an unknown name exits 2."""
    from docs.figures import BLOCKS, main

    assert main(["--list"]) == 0
    listed = [line.split()[0] for line in capsys.readouterr().out.splitlines()]
    assert listed == list(BLOCKS)
    assert main(["--check", "no-such-block"]) == 2
