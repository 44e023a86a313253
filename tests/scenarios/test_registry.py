"""The instrument registry: one line per instrument, read by every room that serves them all."""

import subprocess
import sys

import pytest

from calibench.scenarios import registry
from calibench.scenarios.cli.parser import build_parser
from calibench.scenarios.discover.engine import plugin, supported
from calibench.scenarios.report import BadInput


def test_every_line_names_a_module_that_is_its_instrument():
    for row in registry.instruments():
        s = registry.scenario(row.name)  # imports row.module, which asserts its NAME
        assert s.config.__name__ == row.config and s.renders == row.renders
        if row.discovery:
            assert hasattr(plugin(row.name), "discover")
    assert supported() == registry.NAMES  # every built-in instrument is discovered


def test_the_command_line_lists_the_registry():
    text = build_parser()._subparsers._group_actions[0].choices["discover"].format_help()
    assert all(name in text for name in supported())


def test_an_extension_module_registers_an_instrument_every_process_sees(tmp_path):
    """CALIBENCH_INSTRUMENTS names modules that register instruments when imported: a spawned
    worker, which inherits the environment, sees the same registry."""
    (tmp_path / "ext_rail.py").write_text(
        "from calibench.scenarios.registry import Instrument, register\n"
        "register(Instrument('rail', 'ext_rail', 'RailConfig', run_s=1.0))\n"
    )
    code = (
        "from calibench.scenarios import registry\n"
        "print(registry.NAMES[-1], registry.instrument('rail').run_s)\n"
    )
    env = {"CALIBENCH_INSTRUMENTS": "ext_rail", "PYTHONPATH": str(tmp_path), "PATH": ""}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert out.stdout.split() == ["rail", "1.0"], out.stderr
    env["CALIBENCH_INSTRUMENTS"] = "no_such_module"
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert "CALIBENCH_INSTRUMENTS: cannot import 'no_such_module'" in out.stderr


def test_a_name_is_one_instrument():
    belt = registry.instrument("belt-stage")
    assert registry.register(belt) is belt  # the same line again changes nothing
    with pytest.raises(ValueError, match="registered already"):
        registry.register(registry.Instrument("belt-stage", "elsewhere", "Other"))
    with pytest.raises(BadInput, match="unknown scenario 'rail'"):
        registry.instrument("rail")


def test_a_suite_s_arm_reaches_its_recording():
    """``NAME:ARM`` in the suites is the instrument with that arm: its proof set's recording is
    the UR10's (the instrument's line names the arm, the adapter makes the recording)."""
    from calibench.scenarios.discover.suite import recorded, suite_cases

    assert any(label == "arm-cmm:ur10" for label, _, _ in suite_cases())
    _, manifest = recorded("arm-cmm:ur10", "null", 5000)
    assert manifest["arm"] == "UR10" and manifest["scenario"] == "arm-cmm"
    _, seed_arm = recorded("arm-cmm", "null", 5000)
    assert seed_arm["arm"] != "UR10"


def test_an_instrument_s_own_options_are_on_its_line():
    """``--arm`` and ``--save-images`` belong to the instruments whose lines list them: given to
    another, one line names those that take it; not given, nothing is said."""
    assert registry.takers("--arm") == ("arm-cmm",)
    assert registry.takers("--save-images") == ("belt-stage",)
    with pytest.raises(BadInput, match="--arm applies to arm-cmm, not stewart"):
        registry.check_option("--arm", "ur10", "stewart")
    registry.check_option("--arm", None, "stewart")
    assert registry.FIT_MODELS["arm-cmm"] == "arm" and "stewart" not in registry.FIT_MODELS
