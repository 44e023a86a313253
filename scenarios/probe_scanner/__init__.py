"""Scenario ``probe-scanner``: its line in the registry (``INSTRUMENT``), its config and run
(:mod:`.scenario`) and its rerun layout
(:mod:`.viewer`)."""

from calibench.scenarios.instrument import Instrument

NAME = "probe-scanner"  # the one spelling of its name (its own modules import it)

INSTRUMENT = Instrument(
    NAME,
    f"{__name__}.scenario",
    "ProbeScannerConfig",
    discovery=f"{__name__}.discovery",
    run_s=4.0,
    suite=(
        ("null", 3),
        ("runout", 2),
        ("eccentricity", 1),
        ("scale", 1),
        ("bump", 2),
        ("combined", 1),
        ("drift", 2),
    ),
    unwritten=("null", "thin_wall"),
    simulated=("heated_mount",),
    # a scanner recording covers one parameter, a stage's four: three times the recordings
    coverage=("runout", 3),
    uncertainty=f"{__name__}.uncertainty",
)
