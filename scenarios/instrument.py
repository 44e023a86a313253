"""An instrument's line in the registry: what the rooms that serve every instrument read of it.

Each instrument's package (``calibench.scenarios.<folder>``) holds its own ``INSTRUMENT``; the
registry (:mod:`calibench.scenarios.registry`) collects them. This module imports nothing heavy:
``calibench --help`` reads every line.
"""

from __future__ import annotations

import dataclasses


@dataclasses.dataclass(frozen=True)
class Instrument:
    """One instrument's line in the registry: what every room that serves all instruments (the
    command line, progress, ``discover``, the studies) reads of it, so that an instrument is its
    own modules and this one line.

    Attributes
    ----------
    name : str
        The scenario's name on the command line (``calibench run NAME``).
    module : str
        Its scenario module: ``NAME``, the config class and ``run`` (imported on first use, so
        that ``calibench --help`` and a study's workers load one instrument, not all).
    config : str
        The config class's name in ``module``.
    discovery : str or None
        Its discovery adapter's module (:class:`calibench.scenarios.discover.engine.Plugin`);
        None: ``discover`` does not serve it.
    fit_model : str or None
        The model ``calibench fit`` applies: a stage's map ("quadratic", "cubic"), an arm's
        calibration ("arm"), or None (no ``fit``).
    renders : bool
        Has a camera: ``--fidelity render|analytic`` means something.
    run_s : float
        ``calibench run NAME``'s seconds on 2 busy cores (render where it has a camera),
        measured with ``time calibench run NAME --no-rrd``: the estimate a command says before
        any step has finished.
    suite : tuple of (str, int)
        The concealed-effect suite's cases (:mod:`calibench.scenarios.discover.suite`): each
        concealed kind and how many recordings of it.
    suite_arms : tuple of (str, tuple of (str, int))
        Further arms the suite runs the instrument with (the arm's name, its cases), labelled
        ``NAME:ARM``.
    unwritten : tuple of str
        The second suite's kinds (:mod:`calibench.scenarios.discover.suite_unwritten`): effects
        no candidate writes down, "null" first.
    unwritten_nulls : int
        Null recordings in the second suite (the other kinds take 3).
    simulated : tuple of str
        The third suite's kinds (:mod:`calibench.scenarios.discover.suite_simulated`):
        mechanisms simulated rather than written; its nulls are added.
    simulated_arm : str or None
        The arm the third suite runs the instrument with (labelled ``NAME:ARM``); None: its own.
    options : tuple of str
        The command-line options only it takes (``--arm``: an ARM.toml or a built-in arm;
        ``--save-images``: ``run``'s rendered views for another calibration tool).
    coverage : tuple of (str, int) or None
        The coverage study's concealed kind and recordings per seed asked
        (:mod:`calibench.scenarios.discover.stated_errors`); None: not in the study.
    acceptance : tuple of (str, str)
        The standards' acceptance tests that apply (``calibench acceptance NAME --test``): each
        test's name and the ``module:function`` running its procedure on the twin.
    uncertainty : str or None
        Its task module for ``calibench uncertainty`` (``grid``, ``labels``, ``trial``, ``gum``);
        None: no task is built.
    """

    name: str
    module: str
    config: str
    discovery: str | None = None
    fit_model: str | None = None
    renders: bool = False
    run_s: float = 5.0
    suite: tuple[tuple[str, int], ...] = ()
    suite_arms: tuple[tuple[str, tuple[tuple[str, int], ...]], ...] = ()
    unwritten: tuple[str, ...] = ()
    unwritten_nulls: int = 6
    simulated: tuple[str, ...] = ()
    simulated_arm: str | None = None
    coverage: tuple[str, int] | None = None
    options: tuple[str, ...] = ()
    acceptance: tuple[tuple[str, str], ...] = ()
    uncertainty: str | None = None
