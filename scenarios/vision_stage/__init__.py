"""Scenario ``vision-stage``: its line in the registry (``INSTRUMENT``), its config and run
(:mod:`.scenario`) and its rerun layout
(:mod:`.viewer`)."""

from calibench.scenarios.instrument import Instrument

NAME = "vision-stage"  # the one spelling of its name (its own modules import it)

INSTRUMENT = Instrument(
    NAME,
    f"{__name__}.scenario",
    "VisionStageConfig",
    discovery="calibench.scenarios.stages.discovery",
    fit_model="cubic",
    renders=True,
    run_s=19.0,
    suite=(
        ("null", 4),
        ("backlash", 2),
        ("periodic", 2),
        ("thermal", 1),
        ("combined", 1),
        ("bump", 2),
        ("mixed", 1),
    ),
    unwritten=("null", "presliding", "lagged_thermal", "rail_step"),
    simulated=("heated_scale",),
    coverage=("combined", 1),
    acceptance=(("iso230-2", f"{__name__}.acceptance:iso230_2_test"),),
    uncertainty=f"{__name__}.uncertainty",
)
