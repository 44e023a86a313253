"""The installed package holds every module: pyproject's package list names every package of the
rooms and every data folder (one missing there installs as nothing with ``pip install .``)."""

import tomllib

from tests.conftest import REPO

ROOMS = {
    "calibench": "calibench",
    "calibench.scenes": "scenes",
    "calibench.sim": "sim",
    "calibench.estimators": "estimators",
    "calibench.scenarios": "scenarios",
}


def test_every_package_of_the_rooms_is_installed():
    listed = set(
        tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"]
    )
    found = set()
    for name, folder in ROOMS.items():
        for d in [REPO / folder, *(REPO / folder).rglob("*")]:
            if (
                d.is_dir()
                and d.name != "__pycache__"
                and any(d.glob("*.py")) | any(d.glob("*.toml"))
            ):
                found.add(".".join([name, *d.relative_to(REPO / folder).parts]))
    assert listed == found


def test_the_build_filters_setuptools_editable_notice_and_nothing_else():
    """`make`'s install line sets PYTHONWARNINGS to drop setuptools' notice that an install is
    editable (pip prints it as a warning on every build) and only that: a warning of any other
    text, from pip, setuptools or the build, still shows. (A fresh venv by `make` printed no
    notice and `calibench` imported the working tree's code: checked by hand, issue 59.)"""
    import re
    import subprocess
    import sys

    makefile = (REPO / "Makefile").read_text()
    (line,) = [ln for ln in makefile.splitlines() if "pip install" in ln and "-e '." in ln]
    m = re.search(r'PYTHONWARNINGS="([^"]+)"', line)
    assert m, "the editable install runs without its warning filter"
    # setuptools' own words (setuptools/command/editable_wheel.py, InformationOnly.emit)
    notice = (
        "Editable installation.\\n!!\\n  Please be careful with folders in your working directory"
    )
    other = "License classifiers are deprecated."
    code = f"import warnings; warnings.warn({notice!r}); warnings.warn({other!r})"
    shown = subprocess.run(
        [sys.executable, "-c", code],
        env={"PYTHONWARNINGS": m.group(1)},
        capture_output=True,
        text=True,
        check=True,
    ).stderr
    assert "Editable installation" not in shown and other in shown
