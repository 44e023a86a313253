"""Scenario ``stewart``: its line in the registry (``INSTRUMENT``), its config and run
(:mod:`.scenario`) and its rerun layout
(:mod:`.viewer`)."""

from calibench.scenarios.instrument import Instrument

NAME = "stewart"  # the one spelling of its name (its own modules import it)

INSTRUMENT = Instrument(
    NAME,
    f"{__name__}.scenario",
    "StewartConfig",
    discovery=f"{__name__}.discovery",
    run_s=5.0,
    suite=(("null", 3), ("thermal", 1), ("backlash", 2), ("pitch", 2), ("compliance", 2)),
    unwritten=("null", "stick_slip", "sensor_warmup", "tracker_air"),
    simulated=("heated_leg",),
    unwritten_nulls=3,  # the platform's recordings take 20-40 s each: one null per noise
    uncertainty=f"{__name__}.uncertainty",
)
