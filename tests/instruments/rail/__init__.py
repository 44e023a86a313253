"""The instrument ``rail``: a one-axis stage with a scale error and lost motion, registered by
importing this package (its twin :mod:`.twin`, its scenario :mod:`.scenario`, its least squares
:mod:`.estimator`, its recording format and discovery adapter :mod:`.discovery`)."""

from calibench.scenarios.instrument import Instrument
from calibench.scenarios.registry import register

INSTRUMENT = register(
    Instrument(
        "rail",
        f"{__name__}.scenario",
        "RailConfig",
        discovery=f"{__name__}.discovery",
        run_s=2.0,
        suite=(("null", 2), ("backlash", 1)),
    )
)
