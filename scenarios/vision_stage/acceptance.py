"""ISO 230-2:2014 run on the vision stage's twin, each axis before and after its compensation.

Each axis along one line at mid-travel of the other (the config's middle line; ISO 230-2 tests
an axis along a line, and a table's centre line is its usual one), by the scenario's own
interferometer procedure (:func:`~calibench.scenarios.vision_stage.procedure.interferometer_test`):
``targets_per_line`` targets irregularly spaced over the range the plate calibrated, less 3 mm
at each end (a model is not tested where it extrapolates), ``runs`` bidirectional runs with a
2 mm overrun at each end, the interferometer's reading noise ``interferometer_noise_um``, its
zero at the first target of the first run. Before compensation the table is commanded at the
targets; after, at the seed's cubic's compensated commands (the scenario's ``polynomial``),
the cubic measured on the twin with the analytic microscope as the uncertainty task measures it
(:func:`~calibench.scenarios.vision_stage.uncertainty.calibrated`). The figures are the
standard's (`estimators/stage/iso230_2.py`), in um, per axis.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from calibench.scenarios.iso230 import nonconformity
from calibench.scenarios.vision_stage.procedure import interferometer_lines, interferometer_test
from calibench.scenarios.vision_stage.scenario import VisionStageConfig
from calibench.scenarios.vision_stage.uncertainty import calibrated

FIGURES = ("A", "B", "E", "M", "R")


def iso230_2_test(config: VisionStageConfig, seed: int) -> dict:
    """ISO 230-2's figures of both axes, before and after compensation (um), the targets of
    each axis's line and the procedure in words.

    Parameters
    ----------
    config : the scenario's config.
    seed : the machine's and the runs' seed (the machine drawn as the uncertainty task's
        trial of that seed draws it).

    Returns
    -------
    dict
        ``before`` and ``after``: {``A_x_um``, ``B_x_um``, ..., ``R_y_um``}; ``targets_x_mm``,
        ``targets_y_mm``; ``conforms`` (the set-up is the standard's minimum) and ``reason``
        (why not, or None: :func:`~calibench.scenarios.iso230.nonconformity`); ``procedure``.
    """
    sim, cal = calibrated(config, seed)
    rng = np.random.default_rng([seed, 230])
    mid = np.asarray(config.geometry.travel_mm, float) / 2
    centre = dataclasses.replace(config, x_lines_at_y_mm=(mid[1],), y_lines_at_x_mm=(mid[0],))
    lines = interferometer_lines(centre, rng)
    models = {"before": lambda r: np.zeros_like(r), "after": cal.error_um}
    out: dict = {"before": {}, "after": {}}
    try:
        for which, model in models.items():
            for line in interferometer_test(sim, config, lines, model):
                res = line["iso"].as_dict()
                out[which].update({f"{f}_{line['axis']}_um": res[f] for f in FIGURES})
    finally:
        sim.close()
    why_not = [nonconformity(targets, config.runs) for _, _, targets in lines]
    for axis, _, targets in lines:
        out[f"targets_{'xy'[axis]}_mm"] = targets.round(3).tolist()
    reason = next((w for w in why_not if w), None)
    out["conforms"], out["reason"] = reason is None, reason
    out["procedure"] = (
        f"ISO 230-2:2014 on each axis along the line at mid-travel of the other (X at y = "
        f"{mid[1]:g} mm, Y at x = {mid[0]:g} mm): {config.targets_per_line} targets irregularly "
        "spaced over the range the plate calibrated less 3 mm at each end, "
        f"{config.runs} bidirectional runs with a 2 mm overrun, the interferometer's reading "
        f"noise {config.interferometer_noise_um:g} um, zeroed at the first target; commanded at "
        "the targets before compensation and at the cubic's compensated commands after (the "
        "cubic measured with the circle plate on the twin, analytic microscope)"
    )
    return out
