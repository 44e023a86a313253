"""The run report (docs/formats.md: DIR/report.json), shared by every scenario."""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import numpy as np

from calibench.errors import BadInput  # noqa: F401 - re-exported: the rooms raise it from here
from calibench.writing import write_text


def progress(items, what: str, total: int | None = None):
    """``items``, each reported to the command's progress as ``what k/n`` (a render run takes
    minutes): :func:`calibench.scenarios.progress.steps`, which draws nothing in a study's worker
    or where no command opened a progress."""
    from calibench.scenarios.progress import steps

    return steps(items, what, total)


@dataclasses.dataclass
class Parameter:
    """An estimated quantity that has a truth. ok = |estimate - truth| <= tolerance."""

    name: str
    unit: str
    truth: float
    estimate: float
    std: float | None
    tolerance: float
    crlb: float | None = None  # Cramer-Rao bound on the std, where a scenario computes it

    @property
    def ok(self) -> bool:
        """Whether |estimate - truth| is within the tolerance."""
        return bool(abs(self.estimate - self.truth) <= self.tolerance)

    def as_dict(self) -> dict:
        """The parameter as report.json writes it."""
        out = {
            "name": self.name,
            "unit": self.unit,
            "truth": _num(self.truth),
            "estimate": _num(self.estimate),
            "std": _num(self.std),
            "tolerance": _num(self.tolerance),
            "ok": self.ok,
        }
        if self.crlb is not None:
            out["crlb"] = _num(self.crlb)
        return out


@dataclasses.dataclass
class Check:
    """A named figure with a limit. ``op`` says which side passes: value <= limit or >=.

    A check without a limit (None) is a figure reported for context; it always passes.
    """

    name: str
    value: float
    limit: float | None
    op: str = "<="
    note: str = ""

    @property
    def ok(self) -> bool:
        """Within its limit (on the side ``op`` says); a check without a limit always passes."""
        if self.limit is None:
            return True
        if not math.isfinite(self.value):
            return False
        return bool(self.value <= self.limit if self.op == "<=" else self.value >= self.limit)

    def as_dict(self) -> dict:
        """The check as report.json writes it."""
        d = {
            "name": self.name,
            "value": _num(self.value),
            "limit": _num(self.limit),
            "op": self.op,
            "ok": self.ok,
        }
        if self.note:
            d["note"] = self.note
        return d


@dataclasses.dataclass
class Report:
    """What a run found: every parameter's truth against its estimate, the named checks, extra
    figures (``info``), and where its recording went. ``ok`` when every parameter is within its
    tolerance and every check within its limit; ``write`` makes ``report.json``
    (docs/formats.md)."""

    scenario: str
    seed: int
    fidelity: str
    parameters: list[Parameter] = dataclasses.field(default_factory=list)
    checks: list[Check] = dataclasses.field(default_factory=list)
    info: dict = dataclasses.field(default_factory=dict)  # extra figures, not pass/fail
    rrd: str | None = None
    elapsed_s: float = 0.0

    @property
    def ok(self) -> bool:
        """Every parameter within its tolerance and every check within its limit."""
        return all(p.ok for p in self.parameters) and all(c.ok for c in self.checks)

    def as_dict(self) -> dict:
        """report.json's content (docs/formats.md)."""
        d = {
            "scenario": self.scenario,
            "seed": self.seed,
            "fidelity": self.fidelity,
            "parameters": [p.as_dict() for p in self.parameters],
            "checks": [c.as_dict() for c in self.checks],
            "ok": self.ok,
        }
        if self.rrd is not None:
            d["rrd"] = self.rrd
        d["elapsed_s"] = round(self.elapsed_s, 3)
        if self.info:
            d["info"] = _plain(self.info)
        return d

    def write(self, out_dir: Path) -> Path:
        """Write ``out_dir/report.json``; returns its path."""
        out_dir.mkdir(parents=True, exist_ok=True)
        path = out_dir / "report.json"
        write_text(path, json.dumps(self.as_dict(), indent=2) + "\n")
        return path

    def table(self) -> str:
        """Truth-versus-estimate table in Markdown (for the terminal and the rerun text panel)."""
        lines = [
            "| parameter | unit | truth | estimate | std | tol | ok |",
            "|---|---|---|---|---|---|---|",
        ]
        for p in self.parameters:
            std = "" if p.std is None else f"{p.std:.4g}"
            lines.append(
                f"| {p.name} | {p.unit} | {p.truth:.6g} | {p.estimate:.6g} | {std} | "
                f"{p.tolerance:.3g} | {'yes' if p.ok else 'NO'} |"
            )
        lines += ["", "| check | value | limit | ok |", "|---|---|---|---|"]
        for c in self.checks:
            limit = "" if c.limit is None else f"{c.op} {c.limit:.4g}"
            lines.append(f"| {c.name} | {c.value:.4g} | {limit} | {'yes' if c.ok else 'NO'} |")
        return "\n".join(lines)


def _num(x):
    if x is None:
        return None
    x = float(x)
    return x if math.isfinite(x) else None


def _plain(obj):
    """JSON-ready copy: numpy scalars and arrays to Python numbers and lists."""
    if isinstance(obj, dict):
        return {str(k): _plain(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_plain(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _plain(obj.tolist())
    if isinstance(obj, (np.floating, float)):
        return _num(obj)
    if isinstance(obj, np.integer):
        return int(obj)
    return obj
