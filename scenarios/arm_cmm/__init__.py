"""Scenario ``arm-cmm``: its line in the registry (``INSTRUMENT``), its config and run
(:mod:`.scenario`), its rerun layout (:mod:`.viewer`),
``calibench fit arm-cmm`` (:mod:`.fit`) and the arms as the estimators see them (:mod:`.arms`)."""

from calibench.scenarios.instrument import Instrument

NAME = "arm-cmm"  # the one spelling of its name (its own modules import it)

INSTRUMENT = Instrument(
    NAME,
    f"{__name__}.scenario",
    "ArmCmmConfig",
    discovery=f"{__name__}.discovery",
    fit_model="arm",
    options=("--arm",),
    run_s=4.0,
    suite=(("null", 3), ("eccentricity", 3), ("thermal", 2), ("compliance", 2)),
    suite_arms=(("ur10", (("null", 2), ("eccentricity", 1), ("compliance", 2))),),
    unwritten=("null", "harmonic_drive", "link_bending", "pedestal_warmup"),
    simulated=("gear_play", "encoder_slip"),
    simulated_arm="ur10",
    acceptance=(
        ("iso9283", f"{__name__}.acceptance:iso9283"),
        ("iso10360-12", f"{__name__}.iso10360:iso10360_12"),
    ),
    uncertainty=f"{__name__}.uncertainty",
)
