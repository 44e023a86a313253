"""What a run's instrument recorded: ``DIR/recording.csv``, read by ``fit`` and ``discover`` as a
real recording is, and what was concealed in it, sealed beside it in ``DIR/recording.truth.json``
(which ``discover`` never reads).

The recording is the proof set's plan (``sim/concealed/``) run on the config's twin with the run's
seed: a stage's ISO 230-2 style lines there and back, ``passes`` times; an arm's random postures; a
scanner's turns over its plate; a platform's poses visited out and back under three payloads.
Those plans carry what discovery needs and the runs' own calibration data do not (repeats,
directions of approach, a clock and a logged temperature). The concealed effect of
``[SCENARIO.recording]``'s ``conceal`` is added on top of the twin's own motion (its error map,
drives, chain, rail, legs, as the config gives them), never through an estimator's model.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np

from calibench.errors import BadInput
from calibench.recordings.records import Recording
from calibench.writing import replaced, write_text

RECORDING = "recording.csv"
TRUTH = "recording.truth.json"


@dataclasses.dataclass(frozen=True)
class StageRecordingPlan:
    """``[belt-stage.recording]`` and ``[vision-stage.recording]``.

    Attributes
    ----------
    conceal : str
        The effect concealed in the recording: one of :func:`kinds` (``null``: none beyond the
        twin's own).
    passes : int
        How many times the six lines (three along X, three along Y, each there and back) run;
        at least 2 (discover holds out whole passes and takes its noise from their repeats).
    step_mm : float
        Between stations along a line, mm.
    """

    conceal: str = "null"
    passes: int = 4
    step_mm: float = 6.5


@dataclasses.dataclass(frozen=True)
class ArmRecordingPlan:
    """``[arm-cmm.recording]``.

    Attributes
    ----------
    conceal : str
        The effect concealed (:func:`kinds`).
    postures : int
        How many random postures the reference probes; at least 30.
    reference_noise_um : float
        The reference instrument's 1-sigma per coordinate, um (a laser tracker's).
    """

    conceal: str = "null"
    postures: int = 300
    reference_noise_um: float = 10.0


@dataclasses.dataclass(frozen=True)
class ScannerRecordingPlan:
    """``[probe-scanner.recording]``.

    Attributes
    ----------
    conceal : str
        The effect concealed (:func:`kinds`).
    turns : int
        How many turns over the plate, each of the scanner's samples per turn; at least 2
        (discover holds out whole turns). ``drift`` records 8.
    """

    conceal: str = "null"
    turns: int = 4


@dataclasses.dataclass(frozen=True)
class StewartRecordingPlan:
    """``[stewart.recording]``.

    Attributes
    ----------
    conceal : str
        The effect concealed (:func:`kinds`).
    poses : int
        How many poses, each visited twice (out and back: 2 ``poses`` rows); at least 30
        (discover needs 60 rows: 42 hinge parameters and the tracker's frame).
    """

    conceal: str = "null"
    poses: int = 100


MIN_SIZE = {"passes": 2, "postures": 30, "turns": 2, "poses": 30}
MASSES_NEEDED = ("compliance", "harmonic_drive", "link_bending")  # an arm's kinds under gravity


def kinds(scenario: str) -> tuple[str, ...]:
    """The effects ``conceal`` takes for ``scenario``: its discovery adapter's
    (``recording_kinds``: the proof set's kinds, then the second suite's, which no candidate
    writes down)."""
    from calibench.scenarios.discover.engine import plugin

    return plugin(scenario).recording_kinds(scenario)


def check_plan(scenario: str, plan, travel_mm: tuple[float, float] | None = None) -> None:
    """A ``[SCENARIO.recording]`` table's values, checked with the run's config (BadInput, one line
    naming the key): a known effect, a size the discovery can hold out, a step that gives each
    line of the travel at least three stations."""
    from calibench.scenarios.config import bad

    where = f"{scenario}.recording"
    known = kinds(scenario)
    if plan.conceal not in known:
        raise bad(
            f"{where}.conceal",
            plan.conceal,
            f"not an effect of {scenario} (known: {', '.join(known)})",
        )
    for key, least in MIN_SIZE.items():
        if hasattr(plan, key) and getattr(plan, key) < least:
            raise bad(f"{where}.{key}", getattr(plan, key), f"at least {least}")
    if hasattr(plan, "step_mm"):
        span = min(recorded_travel_mm(scenario, travel_mm))
        if not 0 < plan.step_mm <= span / 2:
            raise bad(
                f"{where}.step_mm",
                plan.step_mm,
                f"from above 0 to {span / 2:g} mm (half the shorter travel the recording covers)",
            )
    if hasattr(plan, "reference_noise_um") and not plan.reference_noise_um >= 0.1:
        raise bad(f"{where}.reference_noise_um", plan.reference_noise_um, "at least 0.1 um")


def recorded_travel_mm(scenario: str, travel_mm: tuple[float, float] | None):
    """The travel a stage's recording covers, (x, y) mm: the proof set's plan's, within the
    twin's travel ``travel_mm`` (None: the plan's)."""
    from calibench.sim.concealed.stage import PLANS

    return tuple(min(a, b) for a, b in zip(PLANS[scenario].travel_mm, travel_mm or (np.inf,) * 2))


def simulate(scenario: str, config, seed: int) -> tuple[Recording, dict]:
    """The recording of ``scenario``'s twin (``config``'s) with ``config.recording``'s effect
    concealed.

    Parameters
    ----------
    scenario : str
        A registered instrument's name: its discovery adapter's ``run_recording`` makes it.
    config : the scenario's config dataclass
        Its ``recording`` table (the plan and the effect), its twin (``truth``, ``geometry``, the
        arm's description).
    seed : int
        Every draw's seed: the same seed, the same recording to the bit.

    Returns
    -------
    recording : StageRecording, ArmRecording, ScannerRecording or StewartRecording
        (n,) rows in the scenario's recording format (mm, deg, s, degC).
    manifest : dict
        The sealed truth: the concealed effects with their parameters, the noise (um), the plan.
    """
    from calibench.scenarios.discover.engine import plugin

    return plugin(scenario).run_recording(scenario, config, seed)


def write_recording(
    out_dir: Path | None, scenario: str, config, seed: int, info: dict
) -> Path | None:
    """Write the run's recording (:func:`simulate`) as ``out_dir/recording.csv`` and what was
    concealed in it as ``out_dir/recording.truth.json``; ``info`` (the report's) is told the
    recording's name. Nothing when ``out_dir`` is None (a Monte-Carlo trial keeps numbers only).

    Returns
    -------
    Path or None
        The recording's path.
    """
    if out_dir is None:
        return None
    Path(out_dir).mkdir(parents=True, exist_ok=True)  # from Python, a folder not yet made
    recording, manifest = simulate(scenario, config, seed)
    path = Path(out_dir) / RECORDING
    with replaced(path) as tmp:
        recording.to_csv(tmp)
    sealed = {
        **manifest,
        "conceal": config.recording.conceal,
        "recording": RECORDING,
        "rows": len(recording),
        "plan": dataclasses.asdict(config.recording),
        "twin": "the run's config (its truth and geometry tables): the effects listed are "
        "concealed on top of it",
    }
    write_text(Path(out_dir) / TRUTH, json.dumps(sealed, indent=1, default=_plain) + "\n")
    info["recording"] = RECORDING
    return path


def _plain(value):
    """numpy's scalars and arrays as JSON's numbers and lists."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    raise TypeError(f"{type(value).__name__} is not JSON")


def check_arm_kind(scenario: str, plan, has_masses: bool, arm_name: str) -> None:
    """An arm's effect under gravity (``compliance``, ``harmonic_drive``, ``link_bending``) needs
    the arm's masses: said before the run (BadInput, one line)."""
    if plan.conceal in MASSES_NEEDED and not has_masses:
        raise BadInput(
            f"config: {scenario}.recording.conceal = {plan.conceal!r}: the arm {arm_name} has no "
            "masses (its ARM.toml's mass_kg), so nothing gives way under gravity"
        )
