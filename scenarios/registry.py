"""The instruments by name: the one table every room that serves them all reads.

Each built-in instrument is a folder of ``calibench.scenarios`` whose package holds its line
(``INSTRUMENT``: :class:`~calibench.scenarios.instrument.Instrument`) and is named once here, in
:data:`BUILT_IN`; a module outside the package registers its own with :func:`register`, imported
through ``CALIBENCH_INSTRUMENTS``. :func:`scenario` gives an instrument's run (its config and
``run``), importing its module alone.
"""

from __future__ import annotations

import contextlib
import dataclasses
from collections.abc import Callable

from calibench.errors import BadInput
from calibench.scenarios.instrument import Instrument


@dataclasses.dataclass(frozen=True)
class Scenario:
    """A scenario by name: its config class, its ``run``, and the model ``calibench fit`` applies.

    ``run(config, seed, fidelity, out_dir, rrd) -> Report``, the same for every scenario:

    config : the scenario's config dataclass
        Geometry, injected truth, sensor noise and check limits (``calibench run --config``).
    seed : int
        Every random draw of the run comes from it: the same seed, the same report to the bit.
    fidelity : str
        "render" (pixels through MuJoCo's renderer and the real detector) or "analytic" (exact
        projection plus the detector's noise); scenarios without a camera (``renders`` False)
        have one fidelity and ignore it.
    out_dir : Path or None
        Where the figure (and ``run.rrd``) go; None writes nothing (a Monte-Carlo trial).
    rrd : bool
        Write the rerun recording ``out_dir/run.rrd`` with the scenario's layout.

    The Report holds truth against estimate (with std and tolerance) for every parameter, and
    the named checks.
    """

    name: str
    config: type
    run: Callable  # (config, seed, fidelity, out_dir, rrd) -> Report
    fit_model: str | None = None  # the calibration model ``calibench fit`` applies
    renders: bool = False  # has a camera: --fidelity render|analytic means something

    def execute(self, config, seed: int, fidelity: str, out_dir, rrd: bool):
        """``run`` with OpenCV single-threaded (its threaded reductions are not bit-reproducible):
        the Report, deterministic from ``seed``; a step of ``run all``'s progress."""
        from calibench.scenarios.progress import part

        with opencv_single_threaded(), part(self.name):
            return self.run(config, seed, fidelity, out_dir, rrd)


@contextlib.contextmanager
def opencv_single_threaded():
    """OpenCV on one thread inside the block, its previous thread count restored after."""
    import cv2

    before = cv2.getNumThreads()
    cv2.setNumThreads(1)
    try:
        yield
    finally:
        cv2.setNumThreads(before)


# The built-in instruments, one line each: the folder in calibench.scenarios whose package holds
# its table (``INSTRUMENT``, a :class:`~calibench.scenarios.instrument.Instrument`).
BUILT_IN = ("belt_stage", "vision_stage", "probe_scanner", "arm_cmm", "stewart")
_INSTRUMENTS: dict[str, Instrument] = {}
# Modules (comma-separated) that register instruments of their own when imported, read once
# here; a study's spawned workers inherit it, and so see the same instruments.
EXTENSIONS_ENV = "CALIBENCH_INSTRUMENTS"


def register(instrument: Instrument) -> Instrument:
    """Add ``instrument`` to the registry (an extension module's one line); a second instrument
    of a registered name is refused: a name is one instrument everywhere."""
    known = _INSTRUMENTS.get(instrument.name)
    if known is not None and known != instrument:
        raise ValueError(f"an instrument named {instrument.name!r} is registered already")
    _INSTRUMENTS[instrument.name] = instrument
    return instrument


def unregister(name: str) -> None:
    """Take ``name``'s line out of the registry (a test's own instrument, once its tests end),
    with its scenario imported for it."""
    _INSTRUMENTS.pop(name, None)
    _built.pop(name, None)


def takers(option: str) -> tuple[str, ...]:
    """The instruments that take the command-line ``option`` (their lines' ``options``)."""
    return tuple(i.name for i in instruments() if option in i.options)


def check_option(option: str, given, name: str) -> None:
    """One line (BadInput) when ``option`` was ``given`` (not None) to an instrument that does
    not take it."""
    if given is not None and name not in takers(option):
        raise BadInput(f"{option} applies to {', '.join(takers(option))}, not {name}")


def instrument(name: str) -> Instrument:
    """The registry's line for ``name``; one clear line (BadInput) for a name it does not hold."""
    if name not in _INSTRUMENTS:
        raise BadInput(f"unknown scenario {name!r} (available: {', '.join(_INSTRUMENTS)})")
    return _INSTRUMENTS[name]


def instruments() -> tuple[Instrument, ...]:
    """Every registered instrument, the built-in ones first, in the order registered."""
    return tuple(_INSTRUMENTS.values())


def _load() -> None:
    """The built-in instruments' tables (their packages import nothing heavy), then the
    extensions'."""
    import importlib
    import os

    for folder in BUILT_IN:
        register(importlib.import_module(f"calibench.scenarios.{folder}").INSTRUMENT)
    for module in filter(None, os.environ.get(EXTENSIONS_ENV, "").split(",")):
        try:
            importlib.import_module(module.strip())
        except ImportError as e:
            raise BadInput(f"{EXTENSIONS_ENV}: cannot import {module.strip()!r} ({e})") from e


def check_fidelity(name: str, fidelity: str | None) -> None:
    """``--fidelity render`` asked of a scenario without a camera: one line (BadInput), not a
    run or study labelled render whose sensors were never rendered."""
    rendering = [i.name for i in instruments() if i.renders]
    if fidelity == "render" and name not in rendering:
        raise BadInput(
            f"--fidelity render applies to the scenarios with a camera ({', '.join(rendering)}); "
            f"{name}'s instruments are geometric, its one fidelity analytic"
        )


_built: dict[str, Scenario] = {}


def scenario(name: str) -> Scenario:
    """The scenario ``name`` (one of :data:`NAMES`), importing its module alone: a Monte-Carlo
    worker of one scenario need not load the others (seconds of start-up on 2 cores)."""
    if name not in _built:
        import importlib

        row = instrument(name)
        m = importlib.import_module(row.module)
        assert m.NAME == name, f"{row.module} is {m.NAME!r}'s, not {name!r}'s"
        _built[name] = Scenario(name, getattr(m, row.config), m.run, row.fit_model, row.renders)
    return _built[name]


def __getattr__(name: str):
    # read when asked, not bound at import: an extension may register after this module loads
    if name == "NAMES":  # tuple of str: every registered instrument's name
        return tuple(_INSTRUMENTS)
    if name == "FIT_MODELS":  # {name: the model ``fit`` applies}
        return {i.name: i.fit_model for i in instruments() if i.fit_model}
    if name == "RENDERING":  # tuple of str: the instruments with a camera
        return tuple(i.name for i in instruments() if i.renders)
    if name == "SCENARIOS":  # {name: Scenario}, every module imported
        return {key: scenario(key) for key in _INSTRUMENTS}
    raise AttributeError(name)


# Scenarios named in docs/formats.md but not built yet (none now).
PLANNED: tuple[str, ...] = ()
_load()
