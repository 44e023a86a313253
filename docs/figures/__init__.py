"""The README's numbers, generated: ``python -m docs.figures`` (or ``make figures``), from the
repository's root.

Every table or sentence of README.md and its pages (docs/*.md) that reports what calibench
computes sits between two marker lines, ``<!-- figures:NAME -->`` and
``<!-- /figures:NAME -->``. Each NAME is a block here: a function that runs the calibench command
or Python API behind those numbers (every one deterministic from its seed) and returns the
block's markdown. The markers stay; the text between them is rewritten.

    python -m docs.figures                    # rewrite every block (README.md, docs/*.md)
    python -m docs.figures NAME...            # rewrite these blocks only
    python -m docs.figures --check [NAME...]  # regenerate and compare with README.md: each number
                                              # beyond its block's tolerance is printed, exit 1
    python -m docs.figures --list             # the blocks, what each runs, its time on 2 cores

``make figures`` and ``make figures-check`` run the first and the third (FIGURES="NAME ..." for
some blocks); tests/test_readme_figures.py checks the blocks marked ``ci``: all but the machine
timings.

The check compares numbers, not words: the numbers of both texts are parsed in order and paired;
a block whose count of numbers differs, or a pair beyond the block's tolerance, is a disagreement.
Machine timings (trials/s, seconds per run) are generated too, by the blocks marked ``timing``
(performance, run-times), with the machine they were measured on; they are never compared.

Generated text holds no literal number: each comes from a run, a computation, or a named constant
(tests/test_readme_figures_prose.py reads the block modules' strings).

The package: :mod:`.engine` (the registry, the README's spans, the numbers and the check, the
command line), :mod:`.runner` (the scratch folder, calibench's commands, the runs blocks share),
:mod:`.fmt` (formatting), and the blocks by instrument or theme, imported below in the order
they run and are listed. The real-data blocks read the project's data/ folder.
"""

import importlib
import os

os.environ.setdefault("MUJOCO_GL", "egl")  # before MuJoCo's first import: renders without a display

from .engine import BLOCKS, main  # noqa: E402

# the blocks register as their modules are imported: this order is the blocks' order
MODULES = (
    "belt_stage",
    "vision_stage",
    "probe_scanner",
    "arm_cmm",
    "ur10_fit",
    "ur10_analysis",
    "stewart",
    "montecarlo",
    "timings",
    "discovery",
    "discovery_unwritten",
    "real_data",
)
for _module in MODULES:
    importlib.import_module(f"{__name__}.{_module}")

__all__ = ["BLOCKS", "MODULES", "main"]
