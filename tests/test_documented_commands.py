"""The commands the README and docs/*.md show run as written (issue 59): every ``calibench`` line
of their code blocks is one the command line takes, with inputs that are in the project or that a
command before it on the same page writes; and the walk from ``run`` to ``discover`` and back
(docs/simulate-and-discover.md) runs whole, in a folder of its own, and finds what it hid."""

import json
import os
import re
import shlex
import subprocess
import sys
from pathlib import Path

import pytest

from tests.conftest import REPO

PAGES = [REPO / "README.md", *sorted((REPO / "docs").glob("*.md")), REPO / "examples" / "README.md"]
WALK = REPO / "docs" / "simulate-and-discover.md"
# a usage line (SCENARIO, [--out DIR], a|b) or an elided one (...) is a summary, not a command
SUMMARY = re.compile(r"\[|\||\.\.\.|\b[A-Z][A-Z0-9_]*(\.csv|\.toml)?\b")


def code_blocks(page: Path) -> list[list[str]]:
    """The page's fenced code blocks, each as its lines, a continued line (``\\``) joined."""
    blocks, current = [], None
    for line in page.read_text().splitlines():
        if line.strip().startswith("```"):
            if current is None:
                current = []
            else:
                blocks.append(current)
                current = None
        elif current is not None:
            if current and current[-1].endswith("\\"):
                current[-1] = current[-1][:-1] + " " + line.strip()
            else:
                current.append(line.strip())
    return blocks


def commands(page: Path) -> list[list[str]]:
    """The page's ``calibench`` command lines that are commands (not usage summaries), each as
    its arguments after ``calibench``, the page's shell variables (``D=data/...``) put in."""
    out, variables = [], {}
    for block in code_blocks(page):
        for line in block:
            assign = re.fullmatch(r"([A-Z]+)=(\S+)", line)
            if assign:
                variables[assign.group(1)] = assign.group(2)
                continue
            if not line.startswith("calibench "):
                continue
            line = line.split("  #")[0].split(" # ")[0]
            for name, value in variables.items():
                line = line.replace(f"${name}", value)
            if "$" in line or SUMMARY.search(line.removeprefix("calibench ")):
                continue
            out.append(shlex.split(line)[1:])
    return out


def written(argv: list[str]) -> list[str]:
    """The paths a command writes: its --out folder (or its verb's default), --twin's file."""
    from calibench.scenarios.cli.folders import default_out

    args = dict(zip(argv, argv[1:]))
    paths = [args[o] for o in ("--out", "--twin", "--save-images") if o in args]
    if argv[0] in ("run", "fit", "discover", "montecarlo") and "--out" not in args:
        paths.append(str(default_out(argv[0], argv[1])))
    return paths


def test_every_documented_command_is_one_the_command_line_takes():
    """Each command line parses, and each file it reads is in the project or written by an earlier
    command (or a ``cat >`` line) of its page."""
    from calibench.scenarios.cli.parser import build_parser

    parser = build_parser()
    seen = 0
    for page in PAGES:
        made = {m for m in re.findall(r"cat > (\S+)", page.read_text())}
        for argv in commands(page):
            seen += 1
            try:
                parser.parse_args(argv)
            except SystemExit as e:  # --help and --version end the parse with status 0
                assert e.code == 0, f"{page.name}: calibench {' '.join(argv)} is refused"
            outputs = set(written(argv))
            for arg in argv[1:]:
                if arg in outputs or not re.search(r"\.(csv|toml|json|jpg|png)$", arg):
                    continue
                if any(arg == m or arg.startswith(f"{m}/") for m in made):
                    continue
                assert (REPO / arg).exists(), f"{page.name}: calibench {' '.join(argv)}: {arg}"
            made.update(written(argv))
    assert seen >= 20  # the pages show that many; a parse that found none would pass anything


def test_default_out_is_what_the_walk_reads():
    """The walk reads calibench-out/belt-stage/recording.csv: run's default folder."""
    assert any(p.endswith("calibench-out/belt-stage") for p in written(["run", "belt-stage"]))


@pytest.mark.slow
def test_the_simulate_and_discover_walk_runs_as_written(tmp_path):
    """docs/simulate-and-discover.md's blocks run in turn in an empty folder (examples/ beside
    it): no command refused or broken (exit 0, or 1 for a run whose own check fails), and each
    discover on a recording that hid an effect names it."""
    (tmp_path / "examples").symlink_to(REPO / "examples")
    env = {**os.environ, "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}"}
    env["CALIBENCH_PROGRESS"] = "off"
    lines = [ln for b in code_blocks(WALK) for ln in b]
    script, heredoc = [], None
    for line in lines:  # the blocks that are commands, not printouts
        if heredoc is not None:
            script[-1] += "\n" + line
            heredoc = None if line == heredoc else heredoc
        elif line.startswith("cat > "):
            script.append(line)
            heredoc = re.search(r"<<'(\w+)'", line).group(1)
        elif line.startswith("calibench "):
            script.append(line)
    assert len(script) >= 12, script
    hidden, checked = {}, 0
    for cmd in script:
        r = subprocess.run(
            ["bash", "-c", cmd], cwd=tmp_path, env=env, capture_output=True, text=True
        )
        assert r.returncode in (0, 1), f"{cmd}: exit {r.returncode}\n{r.stderr}"
        argv = shlex.split(cmd) if not cmd.startswith("cat") else []
        if argv[:2] == ["calibench", "run"]:
            truth = tmp_path / "calibench-out" / argv[2] / "recording.truth.json"
            hidden[argv[2]] = [e["name"] for e in json.loads(truth.read_text())["effects"]]
        if argv[:2] == ["calibench", "discover"] and "--config" not in argv:
            found = json.loads(
                (tmp_path / "calibench-out" / f"{argv[2]}-discover" / "discovery.json").read_text()
            )
            names = {e["name"] for e in found["effects"]}
            assert set(hidden[argv[2]]) <= names, (cmd, hidden[argv[2]], names)
            checked += bool(hidden[argv[2]])
    assert checked >= 5  # the belt stage's hidden backlash and one effect of each other machine
