"""Scenario configuration: frozen dataclasses with defaults, overridden from a TOML table.

A config file holds one table per scenario, nested as the dataclasses are::

    [belt-stage]
    n_intrinsic_views = 25
    [belt-stage.truth]
    board_yaw_rad = 0.002
    [belt-stage.geometry.camera]
    k1 = -0.2
"""

from __future__ import annotations

import dataclasses
import tomllib
from pathlib import Path
from typing import Any

from calibench.scenarios.report import BadInput


def load_toml(path: str | Path) -> dict:
    try:
        with open(path, "rb") as f:
            return tomllib.load(f)
    except OSError as e:
        raise BadInput(f"cannot read config {path}: {e.strerror}") from None
    except tomllib.TOMLDecodeError as e:
        raise BadInput(f"config {path} is not valid TOML: {e}") from None


def override(obj: Any, table: dict, where: str) -> Any:
    """A copy of dataclass ``obj`` with the keys of ``table`` replaced, recursively."""
    names = {f.name for f in dataclasses.fields(obj)}
    changes = {}
    for key, value in table.items():
        if key not in names:
            raise BadInput(f"config: unknown key {where}.{key} (known: {', '.join(sorted(names))})")
        current = getattr(obj, key)
        if dataclasses.is_dataclass(current):
            if not isinstance(value, dict):
                raise BadInput(f"config: {where}.{key} must be a table")
            changes[key] = override(current, value, f"{where}.{key}")
        else:
            changes[key] = _coerce(current, value, f"{where}.{key}")
    try:
        return dataclasses.replace(obj, **changes)
    except (TypeError, ValueError) as e:
        raise BadInput(f"config: {where}: {e}") from None


def _coerce(current: Any, value: Any, where: str) -> Any:
    if isinstance(current, bool):
        if not isinstance(value, bool):
            raise BadInput(f"config: {where} must be true or false")
        return value
    if isinstance(current, (int, float)) and not isinstance(current, bool):
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise BadInput(f"config: {where} must be a number")
        return type(current)(value) if isinstance(current, float) or float(value).is_integer() else value
    if isinstance(current, tuple):
        if not isinstance(value, list):
            raise BadInput(f"config: {where} must be a list")
        return tuple(value)
    return value
