"""Blinded recordings with concealed effects: the proof set for ``calibench discover``.

Separate code from the candidate library (``estimators.effects``): the effects here are written
as the physics of a machine (a drive that lags on reversal, a pulley that runs out, a scale that
warms, a rail with a bump), realised on top of the MuJoCo twin's own motion. The truth goes to a
sealed manifest that ``discover`` never reads; only the suite opens it afterwards.

One module per instrument, each naming its kinds: ``stage`` (belt-stage, vision-stage),
``arm`` (any arm description), ``scanner`` (the probe scanner), ``stewart`` (the Stewart
platform); ``blinded`` writes a recording and its sealed manifest; what the generators share is
written once: a session's generator, the room and the manifest (``sessions``), the effects more
than one instrument has (``effects``).
"""

from calibench.sim.concealed.arm import ARM_KINDS, arm_recording
from calibench.sim.concealed.blinded import write_blinded
from calibench.sim.concealed.scanner import SCANNER_KINDS, scanner_recording
from calibench.sim.concealed.stage import (
    PASS_OFFSET_UM,
    PLANS,
    REFERENCE_NOISE_UM,
    STAGE_KINDS,
    StagePlan,
    stage_commands,
    stage_recording,
)
from calibench.sim.concealed.stewart import (
    STEWART_KINDS,
    STEWART_ROTATION_DEG,
    STEWART_TRANSLATION_MM,
    stewart_poses,
    stewart_recording,
)

__all__ = [
    "ARM_KINDS",
    "PASS_OFFSET_UM",
    "PLANS",
    "REFERENCE_NOISE_UM",
    "SCANNER_KINDS",
    "STAGE_KINDS",
    "STEWART_KINDS",
    "STEWART_ROTATION_DEG",
    "STEWART_TRANSLATION_MM",
    "StagePlan",
    "arm_recording",
    "scanner_recording",
    "stage_commands",
    "stage_recording",
    "stewart_poses",
    "stewart_recording",
    "write_blinded",
]
