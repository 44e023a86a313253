"""Scenario ``belt-stage``: its line in the registry (``INSTRUMENT``), its config and run
(:mod:`.scenario`) and its rerun layout
(:mod:`.viewer`)."""

from calibench.scenarios.instrument import Instrument

NAME = "belt-stage"  # the one spelling of its name (its own modules import it)

INSTRUMENT = Instrument(
    NAME,
    f"{__name__}.scenario",
    "BeltStageConfig",
    discovery="calibench.scenarios.stages.discovery",
    fit_model="quadratic",
    renders=True,
    run_s=14.0,
    suite=(
        ("null", 4),
        ("backlash", 2),
        ("periodic", 2),
        ("thermal", 2),
        ("combined", 2),
        ("bump", 2),
        ("mixed", 1),
        ("elastic", 2),
    ),
    unwritten=("null", "presliding", "lagged_thermal", "rail_step"),
    simulated=("heated_scale",),
    coverage=("combined", 1),
    options=("--save-images",),
    acceptance=(("iso230-2", f"{__name__}.acceptance:iso230_2_test"),),
    uncertainty=f"{__name__}.uncertainty",
)
