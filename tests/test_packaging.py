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
