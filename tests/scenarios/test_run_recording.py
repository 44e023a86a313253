"""`calibench run S` writes DIR/recording.csv: what the instrument recorded, in its scenario's
format, read by `fit` and `discover` as a real recording is; a config conceals an effect in it,
discover finds it, and what was concealed is sealed beside it (recording.truth.json)."""

import io
import json
from pathlib import Path

import numpy as np
import pytest

from calibench.recordings import (
    load_arm_csv,
    load_scanner_csv,
    load_stage_csv,
    load_stewart_csv,
)
from calibench.scenarios.cli import main
from calibench.scenarios.config import load_toml, override
from calibench.scenarios.registry import scenario
from calibench.scenarios.run_recording import simulate

READERS = {
    "belt-stage": load_stage_csv,
    "vision-stage": load_stage_csv,
    "arm-cmm": load_arm_csv,
    "probe-scanner": load_scanner_csv,
    "stewart": load_stewart_csv,
}
# The smallest recordings that still carry each concealed effect (discover's time is the test's):
# two passes or turns (held out whole, their repeats the noise), 100 postures, 30 poses out and
# back. The effect each conceals, and the name and parameter discover gives it.
SMALL = {
    "belt-stage": ("passes = 2\nstep_mm = 20.0", "backlash", "backlash", "reversal_mm"),
    "vision-stage": ("passes = 2\nstep_mm = 10.0", "periodic", "periodic", "amplitude_mm"),
    "arm-cmm": ("postures = 100", "compliance", "joint_compliance", "urad_per_nm"),
    "probe-scanner": ("turns = 2", "runout", "runout", "amplitude_mm"),
    "stewart": ("poses = 30", "backlash", "backlash", "reversal_mm"),
}
SLOW = ("stewart",)  # its discovery calibrates 42 hinge parameters in every fold: ~40 s
CASES = [pytest.param(s, marks=pytest.mark.slow) if s in SLOW else s for s in READERS]


def _run(tmp_path, name: str, table: str, capsys=None) -> tuple[int, object]:
    """``calibench run name --config`` with ``[name.recording]`` = ``table``: status, folder."""
    (tmp_path / "c.toml").write_text(f"[{name}.recording]\n{table}\n")
    out = tmp_path / name
    argv = ["run", name, "--no-rrd", "--out", str(out), "--config", str(tmp_path / "c.toml")]
    if scenario(name).renders:
        argv += ["--fidelity", "analytic"]
    return main(argv), out


@pytest.mark.parametrize("name", CASES)
def test_a_concealed_effect_is_in_the_run_s_recording_and_discover_finds_it(name, tmp_path, capsys):
    """The run's recording loads with its format's reader, `discover` runs on it (0 or 1, never
    bad input or a defect), and the effect concealed by the config is found within 5 of
    discover's standard errors, which it takes from the recording's own noise (its repeats)."""
    size, conceal, found_as, key = SMALL[name]
    status, out = _run(tmp_path, name, f'conceal = "{conceal}"\n{size}')
    assert status in (0, 1)
    assert f"recording -> {out / 'recording.csv'}" in capsys.readouterr().out
    report = json.loads((out / "report.json").read_text())
    assert report["info"]["recording"] == "recording.csv"
    rec = READERS[name](out / "recording.csv")
    truth = json.loads((out / "recording.truth.json").read_text())
    assert truth["conceal"] == conceal and truth["rows"] == len(rec)
    assert main(["discover", name, str(out / "recording.csv"), "--out", str(tmp_path / "d")]) in (
        0,
        1,
    )
    found = json.loads((tmp_path / "d" / "discovery.json").read_text())["effects"]
    assert truth["effects"], truth  # something was hidden, or the loop below checks nothing
    for hidden in truth["effects"]:
        assert hidden["name"] == found_as
        same = [
            e
            for e in found
            if e["name"] == found_as
            and all(
                e["params"].get(k) == hidden["params"][k]
                for k in ("joint", "leg", "harmonic")
                if k in hidden["params"]
            )
        ]
        assert same, f"{hidden} not found among {[e['name'] for e in found]}"
        got, std = same[0]["params"][key], same[0]["stderr"][key]
        assert abs(abs(got) - hidden["params"][key]) <= 5 * std, (got, std, hidden)


def test_every_run_writes_its_recording_in_its_format(tmp_path):
    """Each scenario's default run (analytic) writes recording.csv that its reader loads, with
    the optional columns discover uses (a clock, a temperature; a stage's directions and passes),
    and recording.truth.json saying nothing was concealed."""
    status = main(["run", "all", "--fidelity", "analytic", "--no-rrd", "--out", str(tmp_path)])
    assert status in (0, 1)
    for name, read in READERS.items():
        rec = read(tmp_path / name / "recording.csv")
        truth = json.loads((tmp_path / name / "recording.truth.json").read_text())
        assert truth["conceal"] == "null" and truth["effects"] == [] and len(rec) == truth["rows"]
        assert rec.t_s is not None and rec.temp_c is not None
    stage = load_stage_csv(tmp_path / "belt-stage" / "recording.csv")
    assert stage.dir_x is not None and len(np.unique(stage.run)) == 4


@pytest.mark.parametrize("name", list(READERS))
def test_the_recording_is_deterministic_from_the_seed_and_follows_the_twin(name, tmp_path):
    """The same seed, the same recording to the bit; another seed, another."""
    config = scenario(name).config()
    for seed, path in ((3, "a.csv"), (3, "b.csv"), (4, "c.csv")):
        simulate(name, config, seed)[0].to_csv(tmp_path / path)
    a, b, c = ((tmp_path / p).read_bytes() for p in ("a.csv", "b.csv", "c.csv"))
    assert a == b and a != c


def test_the_twin_s_own_effects_reach_the_recording():
    """A stage twin whose drive loses 12 um on reversal (a `discover --twin` file's table) records
    it, without anything concealed: forward minus backward at the same station is the lost
    motion."""
    name = "belt-stage"
    table = {
        "truth": {"drive_y": {"reversal_at_home_um": 12.0}},
        "recording": {"passes": 2, "step_mm": 40.0},
    }
    config = override(scenario(name).config(), table, name)
    rec, manifest = simulate(name, config, 0)
    assert manifest["effects"] == []
    err = rec.y_meas_mm - rec.y_cmd_mm
    key = np.round(np.c_[rec.x_cmd_mm, rec.y_cmd_mm, rec.run], 6)
    gaps = []
    for k in np.unique(key, axis=0):
        at = np.all(key == k, axis=1)
        up, down = at & (rec.dir_y > 0), at & (rec.dir_y < 0)
        if up.any() and down.any():
            gaps.append(err[up].mean() - err[down].mean())
    assert np.median(gaps) == pytest.approx(0.012, abs=0.002)


@pytest.mark.parametrize(
    "table, fragment",
    [
        (
            '[belt-stage.recording]\nconceal = "gremlins"',
            "belt-stage.recording.conceal = 'gremlins'",
        ),
        ('[vision-stage.recording]\nconceal = "elastic"', "not an effect of vision-stage"),
        ("[belt-stage.recording]\npasses = 1", "belt-stage.recording.passes = 1: at least 2"),
        ("[belt-stage.recording]\nstep_mm = 900.0", "belt-stage.recording.step_mm = 900"),
        # the recording covers 500 x 400 mm of the belt stage's 1 m x 1 m: 250 mm would leave
        # its y lines two stations
        ("[belt-stage.recording]\nstep_mm = 250.0", "belt-stage.recording.step_mm = 250"),
        ("[belt-stage.recording]\nconceal = 3", "must be a string"),
        ("[stewart.recording]\nposes = 5", "stewart.recording.poses = 5: at least 30"),
        ("[probe-scanner.recording]\nturns = 1", "at least 2"),
        ("[arm-cmm.recording]\nreference_noise_um = 0.0", "at least 0.1 um"),
        ("[arm-cmm.recording]\nholes = 3", "unknown key arm-cmm.recording.holes"),
    ],
)
def test_a_bad_recording_table_is_one_line_and_exit_2(table, fragment, tmp_path, capsys):
    """Every key of ``[SCENARIO.recording]`` checked before the run: one line naming it."""
    (tmp_path / "c.toml").write_text(table + "\n")
    name = table[1 : table.index(".")]
    assert (
        main(["run", name, "--config", str(tmp_path / "c.toml"), "--out", str(tmp_path / "o")]) == 2
    )
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "Traceback" not in err and fragment in err, err


EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


@pytest.mark.parametrize(
    "name, stem",
    [
        ("belt-stage", "belt_stage_backlash"),
        ("vision-stage", "vision_stage_periodic"),
        ("arm-cmm", "arm_cmm_compliance"),
        ("probe-scanner", "probe_scanner_runout"),
        ("stewart", "stewart_backlash"),
    ],
)
def test_the_examples_are_what_run_writes(name, stem, tmp_path):
    """examples/STEM.csv is `calibench run NAME --config examples/conceal.toml`'s recording (seed
    0) to the byte, and STEM.truth.json says what it conceals."""
    tables = load_toml(EXAMPLES / "conceal.toml")
    config = override(scenario(name).config(), tables[name], name)
    rec, manifest = simulate(name, config, 0)
    rec.to_csv(tmp_path / "r.csv")
    ours, theirs = (tmp_path / "r.csv").read_text(), (EXAMPLES / f"{stem}.csv").read_text()
    assert ours.splitlines()[0] == theirs.splitlines()[0]  # the same columns
    # the same numbers to the ninth digit written (another BLAS may move the last one)
    a, b = (np.loadtxt(io.StringIO(x), delimiter=",", skiprows=1) for x in (ours, theirs))
    assert a.shape == b.shape and np.allclose(a, b, rtol=1e-7, atol=1e-9)
    sealed = json.loads((EXAMPLES / f"{stem}.truth.json").read_text())
    assert sealed["effects"] == json.loads(json.dumps(manifest["effects"]))
    assert sealed["recording"] == f"{stem}.csv"


def test_a_run_from_python_makes_its_folder(tmp_path):
    """``Scenario.execute`` into a folder not yet made (docs/python.md's example) writes the
    recording there, as the command line does into the folder it claims."""
    sc = scenario("probe-scanner")
    out = tmp_path / "not" / "yet"
    sc.execute(sc.config(), 0, "analytic", out, False)
    assert (out / "recording.csv").is_file() and (out / "figure.png").is_file()
