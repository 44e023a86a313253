"""Issue 62's config inputs: a UTF-8 byte-order mark, and a table no scenario of the command
reads."""

from __future__ import annotations

import pytest

from calibench.scenarios.config import check_tables, load_toml
from calibench.scenarios.report import BadInput

NAMES = ["belt-stage", "vision-stage", "probe-scanner", "arm-cmm", "stewart"]


def test_a_utf8_byte_order_mark_is_read_past(tmp_path):
    (tmp_path / "c.toml").write_bytes("\ufeff[belt-stage]\nn_check = 5\n".encode())
    assert load_toml(tmp_path / "c.toml") == {"belt-stage": {"n_check": 5}}


def test_a_byte_order_mark_inside_is_still_not_toml(tmp_path):
    (tmp_path / "c.toml").write_bytes("[belt-stage]\n\ufeffn_check = 5\n".encode())
    with pytest.raises(BadInput, match="not valid TOML"):
        load_toml(tmp_path / "c.toml")


def test_another_scenarios_table_is_refused_as_montecarlo_refuses_it():
    """`run vision-stage --config c.toml` with only a [belt-stage] table ran the defaults."""
    with pytest.raises(
        BadInput, match=r"takes only its \[vision-stage\] table \(found \[belt-stage\]"
    ):
        check_tables("c.toml", {"belt-stage": {}}, ["vision-stage"], NAMES)
    with pytest.raises(BadInput, match="unknown scenario table"):
        check_tables("c.toml", {"belt-stagee": {}}, ["belt-stage"], NAMES)
    check_tables("c.toml", {"belt-stage": {}, "stewart": {}}, NAMES, NAMES)  # run all
    check_tables("c.toml", {"belt-stage": {}}, ["belt-stage"], NAMES)
    # one file for several scenarios (examples/conceal.toml) serves each of them
    check_tables("c.toml", {"belt-stage": {}, "vision-stage": {}}, ["vision-stage"], NAMES)
    check_tables("c.toml", {}, ["belt-stage"], NAMES)
