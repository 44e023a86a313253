"""arm-cmm end to end through the CLI: the report, the checks, the rrd; and the estimators' chain
made from the arm's description (scenarios.arm_cmm.arms)."""

import dataclasses
import json

import numpy as np
import pytest

from calibench.scenarios.arm_cmm.scenario import ArmCmmConfig, prior, trial_parameters
from calibench.scenarios.cli import main
from calibench.scenarios.rrlog import entity_paths


def test_run_meets_the_acceptance(tmp_path):
    assert main(["run", "arm-cmm", "--seed", "0", "--out", str(tmp_path)]) == 0
    rep = json.loads((tmp_path / "report.json").read_text())
    assert rep["ok"]
    names = {p["name"] for p in rep["parameters"]}
    assert {"da2", "dtheta2"} <= names and "dtheta1" not in names
    # the frames have no reference but the positions: judged by the held-out postures
    assert {"tool_z", "tracker_x"} <= set(rep["info"]["judged_by_holdout"])
    for p in rep["parameters"]:
        assert p["std"] is not None and abs(p["estimate"] - p["truth"]) <= p["tolerance"], p
    c = {ch["name"]: ch for ch in rep["checks"]}
    assert c["probe_rms_before_mm"]["value"] > 0.5
    assert c["probe_rms_after_mm"]["value"] <= 0.02
    assert c["observability_chosen"]["value"] > c["observability_random"]["value"]
    assert "dtheta1" in c["dropped_parameters"]["note"]
    assert "identification_s" not in c and rep["info"]["identification_s"] > 0  # a time: info
    paths = entity_paths(tmp_path / "run.rrd")
    expected = {
        "/world/base/joint1/link1/joint2",
        "/probe/measured",
        "/probe/modelled_after",
        "/residual_mm/before",
        "/residual_mm/after",
    }
    assert expected <= paths, expected - paths


def test_any_arm_by_name_and_a_compliant_one_by_config(tmp_path):
    """--arm ur10 runs the same scenario on the UR10 (its parallel axes keep Hayati's beta); a
    UR10 whose shoulder and elbow give way under MuJoCo's gravity, calibrated for geometry only,
    misses the held-out limit by far: the check fails (exit 1), it does not hide it."""
    assert (
        main(["run", "arm-cmm", "--arm", "ur10", "--no-rrd", "--out", str(tmp_path / "rigid")]) == 0
    )
    rep = json.loads((tmp_path / "rigid" / "report.json").read_text())
    assert {"dbeta2", "dbeta3"} <= {p["name"] for p in rep["parameters"]}
    assert rep["info"]["arm"] == "UR10"
    config = tmp_path / "compliant.toml"
    config.write_text(
        '[arm-cmm]\narm = "ur10"\n[arm-cmm.truth]\nstiffness_nm_per_rad = [inf, 2e5, 1.5e5, inf, '
        "inf, inf]\n"
    )
    assert (
        main(
            ["run", "arm-cmm", "--config", str(config), "--no-rrd", "--out", str(tmp_path / "soft")]
        )
        == 1
    )
    c = {
        ch["name"]: ch
        for ch in json.loads((tmp_path / "soft" / "report.json").read_text())["checks"]
    }
    assert c["probe_rms_after_mm"]["value"] > 0.1


def test_montecarlo_takes_an_arm(tmp_path):
    assert (
        main(
            [
                "montecarlo",
                "arm-cmm",
                "--arm",
                "ur10",
                "--trials",
                "2",
                "--workers",
                "1",
                "--out",
                str(tmp_path),
            ]
        )
        == 0
    )
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["failed"] == 0 and any(
        p.startswith("dbeta2") for p in json.dumps(summary).split('"')
    )
    assert (
        main(
            [
                "montecarlo",
                "arm-cmm",
                "--arm",
                str(tmp_path / "none.toml"),
                "--trials",
                "2",
                "--out",
                str(tmp_path / "x"),
            ]
        )
        == 2
    )


def test_a_solve_that_runs_out_of_iterations_fails_the_run(tmp_path, monkeypatch):
    """Levenberg-Marquardt cut to one iteration: the run reports the solves that did not
    converge as a failed check (exit 1) instead of their last iterate as an answer."""
    from calibench.estimators.identification import solver as ai

    real = ai.identify
    monkeypatch.setattr(ai, "identify", lambda *a, **k: real(*a, **{**k, "max_iter": 1}))
    assert main(["run", "arm-cmm", "--no-rrd", "--out", str(tmp_path)]) == 1
    checks = {c["name"]: c for c in json.loads((tmp_path / "report.json").read_text())["checks"]}
    assert checks["solves_not_converged"]["value"] >= 1 and not checks["solves_not_converged"]["ok"]


@pytest.mark.parametrize("factor", [1.5, 1 / 1.5])
def test_reported_std_stay_honest_when_the_datasheet_is_off(factor):
    """The estimator is told the datasheet's sigma, here 1.5x too large or too small for every
    instrument; the simulation draws the truth's. The identification's variance factor (found in
    its residuals) rescales the covariance, so 95 % intervals still cover 95 % of the errors
    against the effective truth. Band: 200 trials x ~30 parameters, correlated within a trial;
    +-0.02 is about 3 binomial std of 1,000 independent draws. Without the variance factor the
    coverage would be 0.997 (1.5x) or 0.81 (1 / 1.5x)."""
    base = ArmCmmConfig()
    stated = dataclasses.replace(
        base,
        stated_range_sigma_um=tuple(factor * x for x in base.stated_range_sigma_um),
        stated_angle_sigma_urad=factor * base.stated_angle_sigma_urad,
        stated_encoder_sigma_urad=factor * base.stated_encoder_sigma_urad,
    )
    z = []
    for seed in range(200):
        config = prior(stated, np.random.default_rng(10_000 + seed))
        z += [(p.estimate - p.truth) / p.std for p in trial_parameters(config, seed)]
    coverage = np.mean(np.abs(z) <= 1.96)
    assert abs(coverage - 0.95) < 0.02, coverage


@pytest.mark.parametrize("arm", ["arm-cmm", "ur10"])
def test_the_reference_is_what_the_reduced_model_fits_to_mujocos_arm(arm):
    """The reference (injected errors mapped by the known relations, no fit) against the reduced
    model solved on MuJoCo's noise-free tracker readings, for 5 drawn truths: within 5e-3 of the
    parameters' typical sizes (0.5 um, 5 urad; the relations are first order, what is left is
    second order in the 0.1 mm / 1 mrad errors), and the seed's arm's reference covers every
    kinematic error it keeps, the UR10's all but a few wrist ones."""
    from calibench.estimators.arm.kinematics import parameter_scales
    from calibench.estimators.identification.solver import identify, identify_identifiable
    from calibench.scenarios.arm_cmm.arms import chain_of
    from calibench.scenarios.arm_cmm.scenario import reference_values, tracker_problem
    from calibench.sim.arm_cmm import ArmSim

    for k in range(5):
        config = prior(dataclasses.replace(ArmCmmConfig(), arm=arm), np.random.default_rng(k))
        sim = ArmSim(config.arm, config.truth)
        chain = chain_of(sim.arm)
        rng = np.random.default_rng(k)
        q = sim.random_postures(50, rng)
        noisy = tracker_problem(sim, chain, q, sim.encoders(q, rng), rng, config.stated)
        ident = identify_identifiable(noisy)
        exact = tracker_problem(sim, chain, q, q, None)
        exact.R_ref = noisy.R_ref
        fitted = identify(exact, ident.basis)
        assert fitted.rms < 1e-2  # the reduced model reproduces MuJoCo's arm to 1 % of the noise
        ref = reference_values(sim.arm, sim.delta, list(ident.estimate), ident.basis.partners)
        kinematic = [n for n in ident.estimate if not n.startswith(("tool_", "tracker_"))]
        assert len(ref) >= (len(kinematic) if arm == "arm-cmm" else len(kinematic) - 3)
        for name, value in ref.items():
            assert abs(value - fitted.estimate[name]) < 5e-3 * parameter_scales([name])[0], (
                k,
                name,
            )


def _field_values_equal(a, b) -> bool:
    return (a is None and b is None) or (
        a is not None and b is not None and np.array_equal(np.asarray(a), np.asarray(b))
    )


@pytest.mark.parametrize("arm_name", ["arm-cmm", "ur10", "massless"])
def test_the_chain_is_the_description_field_for_field(arm_name):
    """Every field of the description is the chain's field of that name (as an array) or one it
    says it does without; the methods both have agree."""
    from calibench.estimators.arm.kinematics import Chain
    from calibench.scenarios.arm_cmm.arms import NOT_IN_CHAIN, chain_of
    from calibench.scenes.arm_cmm import ArmDescription, arm_from_table, load_arm

    if arm_name == "massless":  # no masses: the optional fields are None in both forms
        joint = {"a_mm": 300.0, "d_mm": 100.0, "alpha_deg": 90.0}
        arm = arm_from_table({"convention": "mdh", "joint": [joint] * 3}, "massless.toml")
    else:
        arm = load_arm(arm_name)
    chain = chain_of(arm)
    chain_fields = {f.name for f in dataclasses.fields(Chain)}
    for f in dataclasses.fields(ArmDescription):
        if f.name in NOT_IN_CHAIN:
            assert f.name not in chain_fields
            continue
        assert _field_values_equal(getattr(chain, f.name), getattr(arm, f.name)), f.name
    assert chain.n_joints == arm.n_joints and chain.has_masses == arm.has_masses
    assert np.array_equal(chain.nominal(), arm.nominal())
    assert chain.has_masses == (arm_name != "massless")


def test_a_field_added_to_the_description_is_not_forgotten_by_the_chain(monkeypatch):
    """A description with a field the chain does not take, and that no one said it does without,
    is refused by name; said, it passes. A field the chain takes and the description lacks is
    refused too."""
    from calibench.estimators.arm.kinematics import Chain
    from calibench.scenarios.arm_cmm import arms
    from calibench.scenes.arm_cmm import ArmDescription, load_arm

    ur10 = load_arm("ur10")
    Payload = dataclasses.make_dataclass(
        "Payload", [("payload_kg", float, 0.0)], bases=(ArmDescription,), frozen=True
    )
    arm = Payload(**{f.name: getattr(ur10, f.name) for f in dataclasses.fields(ur10)})
    with pytest.raises(TypeError, match="payload_kg"):
        arms.chain_of(arm)
    monkeypatch.setitem(arms.NOT_IN_CHAIN, "payload_kg", "a test's")
    assert arms.chain_of(arm).n_joints == ur10.n_joints
    Stiff = dataclasses.make_dataclass(
        "Stiff", [("stiffness_nm_per_rad", object, None)], bases=(Chain,), frozen=True
    )
    monkeypatch.setattr(arms, "Chain", Stiff)
    with pytest.raises(AttributeError, match="stiffness_nm_per_rad"):
        arms.chain_of(ur10)
