"""How honest the seed arm's reported std stay when the datasheet is wrong: the 95 % coverage of
its identification over truths drawn from the prior, with every stated sigma scaled by a factor
(the README's arm-cmm-datasheet figures; tests/scenarios/test_arm_cmm.py draws the same)."""

from __future__ import annotations

import dataclasses

import numpy as np

from calibench.estimators.identification.solver import identify_identifiable
from calibench.scenarios.arm_cmm.arms import chain_of
from calibench.scenarios.arm_cmm.references import reference_values
from calibench.scenarios.arm_cmm.scenario import ArmCmmConfig, prior, tracker_problem
from calibench.sim.arm_cmm import ArmSim

Z_95 = 1.96  # the half-width of a 95 % interval, in std
PRIOR_SEED0 = 10_000  # trial k draws its truth from the prior with seed PRIOR_SEED0 + k


def datasheet_coverage(factor: float, trials: int) -> tuple[float, float]:
    """The 95 % coverage of the seed arm's tracker identification with the datasheet's sigma
    ``factor`` x the truth's, over ``trials`` truths drawn from its prior.

    Trial k draws its truth with seed ``PRIOR_SEED0 + k`` and runs the Monte-Carlo unit
    (scenarios.arm_cmm's ``trial_parameters``) up to the identification with seed k; each kept
    parameter with a reference (``reference_values``) gives one normalised error.

    Parameters
    ----------
    factor : float
        Every stated sigma (range, angles, encoders) times this.
    trials : int
        Truths drawn.

    Returns
    -------
    tuple of float
        The share of normalised errors within +-``Z_95``: as reported (the std carry the
        residuals' variance factor), and without that factor (the std divided by the
        identification's whitened RMS, i.e. as the datasheet alone gives them).
    """
    base = ArmCmmConfig()
    stated = dataclasses.replace(
        base,
        stated_range_sigma_um=tuple(factor * x for x in base.stated_range_sigma_um),
        stated_angle_sigma_urad=factor * base.stated_angle_sigma_urad,
        stated_encoder_sigma_urad=factor * base.stated_encoder_sigma_urad,
    )
    z, z_raw = [], []
    for seed in range(trials):
        config = prior(stated, np.random.default_rng(PRIOR_SEED0 + seed))
        rng = np.random.default_rng(seed)
        sim = ArmSim(config.arm, config.truth)
        q = sim.random_postures(config.n_postures, rng)
        ident = identify_identifiable(
            tracker_problem(sim, chain_of(sim.arm), q, sim.encoders(q, rng), rng, config.stated)
        )
        ref = reference_values(sim.arm, sim.delta, list(ident.estimate), ident.basis.partners)
        for name, value in ref.items():
            err = ident.estimate[name] - value
            z.append(err / ident.std[name])
            z_raw.append(err / (ident.std[name] / ident.rms))
    return float(np.mean(np.abs(z) <= Z_95)), float(np.mean(np.abs(z_raw) <= Z_95))
