"""``calibench discover``: where a recording disagrees with its twin, and which physics is missing.

One engine (``calibench.estimators.discovery``: candidates, held-out selection, localisation,
the nonsmooth table) and an adapter per instrument, its ``discovery`` module, named by its line
in the registry (the stages share ``calibench.scenarios.stages.discovery``). An adapter is a
module that follows :class:`Plugin`:

1. ``load`` reads the recording(s) in docs/formats.md's format (one clear BadInput line for any
   defect);
2. ``discover`` replays it with the twin (the nominal one, or the one of a ``run --config``
   file) and forms its signals (recording minus twin) and the scene model's free columns (what a
   user calibrates anyway: a stage's error map, an arm's base frame and tool, a scanner's rail,
   a platform's tracker frame); builds its typed drivers (the ``*Drivers`` of its candidates'
   module in ``estimators.discovery``), its candidates and its folds (held-out scheme, said in
   discovery.json's ``holdout``); runs the engine's selection; and says what it found in plain
   words (each effect's ``physics``, the ``verdict``, what is ``confounded`` and the experiment
   that would separate it);
3. ``twin_tables`` maps the accepted effects onto the instrument's twin (a ``run --config``
   file): ``discover --twin`` writes it, ``discover --config`` replays a recording with it, and
   ``run`` / ``montecarlo`` simulate the machine with what was found. Effects the simulation has
   no parameter for (a drift with time, a nonsmooth table) are listed as not carried.

Writes DIR/discovery.json (docs/formats.md) and DIR/discovery.png (residuals before and after).
"""

from __future__ import annotations

import importlib
import json
from collections.abc import Sized
from pathlib import Path
from typing import Protocol

import numpy as np
from threadpoolctl import threadpool_limits

from calibench.files import first_repeat, same_file
from calibench.recordings.records import Recording
from calibench.scenarios.discover.confirm import confirm
from calibench.scenarios.discover.figure import write_figure
from calibench.scenarios.discover.twin_merge import split_confirmed, twin_note
from calibench.scenarios.progress import stage
from calibench.scenarios.provenance import entry
from calibench.scenarios.report import BadInput
from calibench.writing import replaced, write_text

# Rows per recording: the candidates' design matrices grow with it (a 1e6-row stage recording
# would need tens of GB); refused before any work, with the advice to decimate.
MAX_ROWS = 100_000


class Plugin(Protocol):
    """An instrument's discovery (a module of ``calibench.scenarios.discover``).

    Attributes
    ----------
    HOLDOUTS : tuple of str
        The held-out schemes ``--holdout`` may name for it (empty: the plug-in's own folds).
    MANY_RECORDINGS : bool
        Whether it takes several recordings at once (each in its own frame).
    """

    HOLDOUTS: tuple[str, ...]
    MANY_RECORDINGS: bool

    def load(self, scenario: str, paths: list[Path], arm) -> Sized:
        """The recording(s) at ``paths``, read in docs/formats.md's format (``arm``: an ARM.toml or
        a built-in arm's name, for the arm; None elsewhere)."""
        ...

    def discover(
        self, scenario: str, rec, seed: int, holdout: str | None, config: Path | None, arm
    ) -> tuple[dict, dict]:
        """discovery.json's content and the figure's data: ``rec`` replayed by the twin of the
        ``run --config`` file ``config`` (None: the scenario's nominal twin)."""
        ...

    def twin_tables(
        self, scenario: str, found: dict, config: Path | None, arm
    ) -> tuple[dict, list[str]]:
        """The twin file's tables with what ``found`` (discovery.json's content) accepted, on top
        of ``config``'s twin, and the accepted effects the simulation cannot carry."""
        ...

    def concealed(
        self, scenario: str, kind: str, seed: int, arm: str | None = None, **options
    ) -> tuple[Recording, dict]:
        """The suites' proof set: a recording of the nominal twin (``arm``: which arm, for an
        arm) with ``kind`` concealed, made by the twin's physics, and its sealed manifest
        (``effects``: name, axis, params; ``noise_um``); ``options``: ``noise`` (a reading-noise
        kind of ``sim.concealed.noise``), ``repeat`` (1: the same machine recorded again)."""
        ...

    def search(
        self, scenario: str, rec, seed: int, floor: float | None = None, arm: str | None = None
    ) -> tuple[dict, dict]:
        """``discover``'s search on ``rec`` with the nominal twin: discovery.json's content and
        the figure's (``floor``: the acceptance floor; None: the instrument's own)."""
        ...

    def recording_kinds(self, scenario: str) -> tuple[str, ...]:
        """The effects ``run``'s recording may conceal (``[SCENARIO.recording]``'s ``conceal``)."""
        ...

    def nonsmooth_at(self, scenario: str, truth: dict, found: dict) -> bool:
        """Whether a found ``nonsmooth`` table sits where a concealed local effect lives (a
        rail's step, a plate's thin wall: the second suite's scoring); only the adapters whose
        proof set conceals one need it."""
        ...

    def run_recording(self, scenario: str, config, seed: int) -> tuple[Recording, dict]:
        """``run``'s ``recording.csv``: the proof set's plan on the config's twin with
        ``config.recording``'s effect concealed, and the sealed manifest."""
        ...


def supported() -> tuple[str, ...]:
    """The instruments ``discover`` serves: the registry's with a discovery adapter."""
    from calibench.scenarios.registry import instruments

    return tuple(i.name for i in instruments() if i.discovery)


def plugin(scenario: str) -> Plugin:
    """The discovery plug-in of ``scenario`` (BadInput for a scenario discover has none for)."""
    from calibench.scenarios.registry import NAMES, instrument

    module = instrument(scenario).discovery if scenario in NAMES else None
    if module is None:
        raise BadInput(f"discover supports {', '.join(supported())}, not {scenario!r}")
    return importlib.import_module(module)


PROVENANCE_NOTE = (
    "discover chooses the model's structure (its candidates, their frequencies and band edges) "
    "on every row it reads, and its held-out figures (cv_rms_*) are the selection's own: "
    "in-sample for what it chose. Score it on rows it did not read."
)


def discovery_provenance(paths: list[Path], rows_used: list[np.ndarray]) -> dict:
    """discovery.json's ``provenance``: per recording (by name and content hash) the rows that
    chose the model's structure, fitted it and scored it (all the rows discover used)."""
    return {
        "recordings": [entry(p, chose=r, fitted=r, scored=r) for p, r in zip(paths, rows_used)],
        "note": PROVENANCE_NOTE,
    }


# the searches score their candidates on a thread pool that fills the cores: a BLAS pool under
# each thread oversubscribed them (the Stewart platform's discovery 2-4 times slower on 2 cores)
@threadpool_limits.wrap(limits=1)
def run_discover(
    scenario: str,
    csv_path,
    out_dir: Path,
    seed: int = 0,
    holdout: str | None = None,
    arm: str | Path | None = None,
    config: Path | None = None,
    twin: Path | None = None,
) -> dict:
    """``calibench discover``: the plug-in of ``scenario`` on the recording(s) ``csv_path``
    (several for an instrument that takes them, each in its own frame); with ``config`` (a
    ``run --config`` file) its twin replays the recording, beside the nominal twin's replay;
    ``twin``: where to write the twin updated with what was found (the same format). Writes
    ``out_dir``/discovery.json and discovery.png; returns discovery.json's content."""
    paths = list(csv_path) if isinstance(csv_path, (list, tuple)) else [csv_path]
    twice = first_repeat(paths)  # a recording given twice would count its rows twice
    if twice is not None:
        raise BadInput(f"{twice} is given twice: each recording once")
    many = scenario in supported() and plugin(scenario).MANY_RECORDINGS
    if not many and len(paths) != 1:
        raise BadInput(f"discover {scenario}: one recording, not {len(paths)}")
    if config is not None:
        from calibench.scenarios.config import load_toml

        tables = load_toml(config)
        if scenario not in tables:
            raise BadInput(
                f"config {config} has no [{scenario}] table (it has: "
                f"{', '.join(tables) or 'none'}): its twin is not this instrument's"
            )
    if twin is not None and any(same_file(twin, p) for p in paths):
        raise BadInput(f"--twin {twin} is a recording of this run: the twin would overwrite it")
    found_by = plugin(scenario)
    if holdout is not None and holdout not in found_by.HOLDOUTS:
        stages = ", ".join(s for s in supported() if plugin(s).HOLDOUTS)
        raise BadInput(
            f"--holdout {holdout}: for the stages ({stages}); discover {scenario} holds out "
            "its own folds (an arm's and a platform's contiguous blocks, a scanner's turns)"
        )

    def once(cfg: Path | None) -> tuple[dict, dict]:
        rec = found_by.load(scenario, paths, arm)
        out, fig = found_by.discover(scenario, rec, seed, holdout, cfg, arm)
        if "rows_used" not in fig:  # the plug-in read every row
            fig["rows_used"] = [np.arange(len(rec))]
        fig["recording"] = rec
        return out, fig

    stage("searching what the twin misses")
    out, fig = once(config)
    stage("confirming under the other hold-outs")
    confirm(found_by, scenario, fig.pop("recording"), seed, holdout, config, arm, out)
    out["provenance"] = discovery_provenance(paths, fig["rows_used"])
    before = None
    if config is not None:  # the nominal twin's residual beside the updated one's, both replayed
        out["replayed_config"] = str(config)
        stage("replaying the nominal twin")
        try:
            nominal, before = once(None)
        except BadInput as e:  # the config's geometry reaches where the nominal twin cannot
            out["nominal_twin_fit"] = None
            out["nominal_twin_not_replayed"] = str(e)
        else:
            before.pop("recording")
            out["nominal_twin_fit"] = nominal["fit"]
    if twin is not None:
        # only what discovery confirmed goes into the twin: an effect a held-out scheme rejects,
        # simulated as the machine's, would fail the twin's own run (and is said, not carried)
        kept, unconfirmed = split_confirmed(out["effects"])
        tables, left = found_by.twin_tables(scenario, {**out, "effects": kept}, config, arm)
        write_toml(twin, tables, twin_note(paths[0], left, unconfirmed))
        out["twin"] = {"path": str(twin), "not_carried": left, "not_confirmed": unconfirmed}
    out_dir.mkdir(parents=True, exist_ok=True)
    write_text(out_dir / "discovery.json", json.dumps(out, indent=2, default=json_default) + "\n")
    stage("drawing discovery.png")
    with replaced(out_dir / "discovery.png") as tmp:
        write_figure(tmp, out, fig, before)
    return out


def write_toml(path: Path, tables: dict, comment: str) -> None:
    """A config file (nested tables of numbers, booleans, strings and lists of them) for ``run
    --config``."""

    def value(v):
        if isinstance(v, (list, tuple)):
            return "[" + ", ".join(value(x) for x in v) + "]"
        if isinstance(v, (bool, np.bool_)):  # before int: a bool is one
            return "true" if v else "false"
        if isinstance(v, str):  # a user's own table carried over (JSON's escapes are TOML's)
            return json.dumps(v, ensure_ascii=False).replace("\x7f", "\\u007f")
        return repr(int(v)) if isinstance(v, (int, np.integer)) else repr(float(v))

    lines = [f"# {line}" for line in comment.splitlines()]

    def table(prefix, d):
        plain = {k: v for k, v in d.items() if not isinstance(v, dict)}
        if plain:
            lines.append(f"\n[{prefix}]")
            lines.extend(f"{k} = {value(v)}" for k, v in plain.items())
        for k, v in d.items():
            if isinstance(v, dict):
                table(f"{prefix}.{k}", v)

    for name, d in tables.items():
        table(name, d)
    try:
        write_text(path, "\n".join(lines) + "\n")
    except OSError as e:
        raise BadInput(f"cannot write the twin {path}: {e.strerror}") from None


def json_default(o):
    """numpy scalars as Python numbers, for json.dumps."""
    if isinstance(o, (np.floating, np.integer)):
        return o.item()
    raise TypeError(type(o))
