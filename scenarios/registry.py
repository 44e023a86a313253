"""The scenarios by name: each declares its config, its run, and its model for ``fit``."""

from __future__ import annotations

import contextlib
import dataclasses
from collections.abc import Callable

from calibench.errors import BadInput


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


# name: (module, config class, fit model, renders). A module is imported by scenario(name), one at
# a time, so that ``calibench --help``, a user's ``import`` and a study's workers stay quick.
_TABLE = {
    "belt-stage": ("belt_stage", "BeltStageConfig", "quadratic", True),
    "vision-stage": ("vision_stage", "VisionStageConfig", "cubic", True),
    "probe-scanner": ("probe_scanner", "ProbeScannerConfig", None, False),
    "arm-cmm": ("arm_cmm", "ArmCmmConfig", None, False),
    "stewart": ("stewart", "StewartConfig", None, False),
}
NAMES: tuple[str, ...] = tuple(_TABLE)
FIT_MODELS = {name: row[2] for name, row in _TABLE.items() if row[2]}
RENDERING: tuple[str, ...] = tuple(name for name, row in _TABLE.items() if row[3])


def check_fidelity(name: str, fidelity: str | None) -> None:
    """``--fidelity render`` asked of a scenario without a camera: one line (BadInput), not a
    run or study labelled render whose sensors were never rendered."""
    if fidelity == "render" and name not in RENDERING:
        raise BadInput(
            f"--fidelity render applies to the scenarios with a camera ({', '.join(RENDERING)}); "
            f"{name}'s instruments are geometric, its one fidelity analytic"
        )


_built: dict[str, Scenario] = {}


def scenario(name: str) -> Scenario:
    """The scenario ``name`` (one of :data:`NAMES`), importing its module alone: a Monte-Carlo
    worker of one scenario need not load the others (seconds of start-up on 2 cores)."""
    if name not in _built:
        import importlib

        module, config, fit_model, renders = _TABLE[name]
        m = importlib.import_module(f"calibench.scenarios.{module}.scenario")
        assert m.NAME == name
        _built[name] = Scenario(name, getattr(m, config), m.run, fit_model, renders)
    return _built[name]


def __getattr__(name: str):
    if name != "SCENARIOS":
        raise AttributeError(name)
    return {key: scenario(key) for key in _TABLE}


# Scenarios named in docs/formats.md but not built yet (none now).
PLANNED: tuple[str, ...] = ()
