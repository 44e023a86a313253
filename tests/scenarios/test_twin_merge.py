"""``discover --twin`` on top of a replayed twin (scenarios/discover/twin_merge.py): two
expansions or two periodic errors of one drive written as one must be their sum, at every
temperature and position."""

import numpy as np

from calibench.scenarios.discover.twin_merge import carried, periodic_on_top, thermal_on_top


def test_two_expansions_are_one_at_every_temperature():
    rng = np.random.default_rng(5)
    k1, r1, k2, r2 = 12.0, 20.0, -4.5, 23.7
    k, ref = thermal_on_top(k1, r1, k2, r2)
    T = rng.uniform(10, 40, 50)
    np.testing.assert_allclose(k * (T - ref), k1 * (T - r1) + k2 * (T - r2), rtol=0, atol=1e-12)
    assert thermal_on_top(0.0, 20.0, k2, r2) == (k2, r2)  # a twin without one: as found
    assert thermal_on_top(3.0, 20.0, -3.0, 25.0) is None  # a constant scale error is left


def test_two_periodic_errors_of_one_period_are_one_at_every_position():
    rng = np.random.default_rng(6)
    u = rng.uniform(0, 500, 80)
    a, period, ph = periodic_on_top(6.0, 40.0, 0.3, 2.5, 40.0, 2.9)
    wave = lambda a, p, ph: a * np.sin(2 * np.pi * u / p + ph)  # noqa: E731
    np.testing.assert_allclose(
        wave(a, period, ph), wave(6.0, 40.0, 0.3) + wave(2.5, 40.0, 2.9), rtol=0, atol=1e-12
    )
    assert periodic_on_top(0.0, 0.0, 0.0, 2.5, 31.0, 1.0) == (2.5, 31.0, 1.0)
    assert periodic_on_top(6.0, 40.0, 0.3, 2.5, 31.0, 1.0) is None  # one drive, one period


def test_a_config_s_tables_are_kept_under_the_update():
    given = {"geometry": {"travel_mm": [1.0, 2.0]}, "truth": {"a": 1.0, "b": 2.0}, "n": 3}
    out = carried(given, {"truth": {"b": 5.0, "c": 6.0}})
    assert out == {
        "geometry": {"travel_mm": [1.0, 2.0]},
        "truth": {"a": 1.0, "b": 5.0, "c": 6.0},
        "n": 3,
    }
    assert given["truth"] == {"a": 1.0, "b": 2.0}  # the given table is not changed


def test_the_twin_carries_only_what_discovery_confirmed(tmp_path, capsys):
    """The paper's belt stage: discover accepts a 223 mm periodic term of X holding out rows
    but not columns. The twin leaves it out (no periodic error in drive_x), says so in its
    header, in discovery.json and on the console, and `run --config` of it passes its checks."""
    import json
    import tomllib
    from pathlib import Path

    from calibench.scenarios.cli import main

    paper = Path(__file__).resolve().parents[2] / "examples" / "belt_stage_paper.csv"
    twin = tmp_path / "twin.toml"
    argv = ["discover", "belt-stage", str(paper), "--twin", str(twin), "--out", str(tmp_path / "d")]
    assert main(argv) == 0
    found = json.loads((tmp_path / "d" / "discovery.json").read_text())
    (periodic,) = [e for e in found["effects"] if e["name"] == "periodic"]
    assert periodic["status"] == "not confirmed" and periodic["axis"] == "x"
    assert "periodic (x)" in found["twin"]["not_confirmed"]
    assert tomllib.loads(twin.read_text())["belt-stage"]["truth"]["drive_x"]["periodic_um"] == 0
    header = [ln for ln in twin.read_text().splitlines() if ln.startswith("#")]
    assert any("NOT CONFIRMED" in ln and "periodic (x)" in ln for ln in header)
    assert "not written into it, NOT CONFIRMED: periodic (x)" in capsys.readouterr().out
    run = ["run", "belt-stage", "--config", str(twin), "--fidelity", "analytic", "--no-rrd"]
    assert main([*run, "--out", str(tmp_path / "r")]) == 0
