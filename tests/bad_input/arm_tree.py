"""Bad-input cases, branched arms (issue 63): an ARM.toml's tree (a parent that is no joint,
comes after its child or closes a cycle; a joint that follows itself, no joint or another
follower; a tool on no joint) and a recording's ``tool`` column naming a tool the arm lacks.

See tests/test_bad_input.py, which runs every case.
"""

from __future__ import annotations

import numpy as np

from tests.bad_input.files import arm_csv, arm_rows

# a torso joint carrying two one-joint arms, a tool on each
TREE_TOML = """name = "Tree"
convention = "dh"
[[joint]]
a_mm = 0.0
d_mm = 400.0
alpha_deg = -90.0
[[joint]]
a_mm = 300.0
d_mm = 100.0
alpha_deg = 0.0
[[joint]]
parent = 1
a_mm = 300.0
d_mm = -100.0
alpha_deg = 0.0
[[tool]]
parent = 2
offset_mm = [50.0, 0.0, 0.0]
[[tool]]
parent = 3
offset_mm = [50.0, 0.0, 0.0]
"""


def _tree(old: str, new: str) -> str:
    """The tree's file with its first ``old`` replaced by ``new``."""
    assert old in TREE_TOML
    return TREE_TOML.replace(old, new, 1)


def _recording(tool: float):
    """A writer of a well-formed 3-joint recording whose last row measures tool ``tool``."""

    def write(path):
        q, xyz = arm_rows(n_joints=3)
        head, *rows = arm_csv(q, xyz).splitlines()
        tools = np.ones(len(rows))
        tools[-1] = tool
        cells = [f"{r},{t:g}" for r, t in zip(rows, tools)]
        path.write_text("\n".join([f"{head},tool"] + cells) + "\n")

    return write


def _fit(case: str, toml: str, fragment: str) -> tuple:
    """A ``fit arm-cmm`` case of the arm file ``toml`` (said before the recording is read)."""
    return (
        case,
        {"a.toml": toml, "r.csv": lambda p: p.write_text(arm_csv(*arm_rows(n_joints=3)))},
        ["fit", "arm-cmm", "{d}/r.csv", "--arm", "{d}/a.toml"],
        2,
        fragment,
    )


CASES = [
    _fit("arm-parent-no-joint", _tree("parent = 1", "parent = 7"), "parent = 7: no such joint"),
    _fit("arm-parent-negative", _tree("parent = 1", "parent = -1"), "parent = -1: no such joint"),
    _fit("arm-parent-not-whole", _tree("parent = 1", "parent = 1.5"), "must be a whole number"),
    _fit("arm-parent-itself", _tree("parent = 1", "parent = 3"), "is the joint itself"),
    _fit(
        "arm-parent-after",
        _tree("a_mm = 300.0\nd_mm = 100.0", "parent = 3\na_mm = 300.0\nd_mm = 100.0"),
        "joint 2: parent = 3 comes after it",
    ),
    _fit(
        "arm-parent-cycle",
        _tree("a_mm = 300.0\nd_mm = 100.0", "parent = 3\na_mm = 300.0\nd_mm = 100.0").replace(
            "parent = 1", "parent = 2"
        ),
        "joints 2 -> 3 -> 2 form a cycle",
    ),
    _fit(
        "arm-follows-itself",
        _tree("parent = 1", "parent = 1\nfollows = [[3, 0.5]]"),
        "joint 3: follows joint 3, itself",
    ),
    _fit(
        "arm-follows-no-joint",
        _tree("parent = 1", "parent = 1\nfollows = [[1, 0.5], [9, 0.5]]"),
        "follows joint 9: no such joint",
    ),
    _fit(
        "arm-follows-a-follower",
        _tree("parent = 1", "parent = 1\nfollows = [[2, 0.5]]").replace(
            "d_mm = 100.0", "d_mm = 100.0\nfollows = [[1, 1.0]]"
        ),
        "which follows others itself",
    ),
    _fit(
        "arm-follows-not-pairs",
        _tree("parent = 1", "parent = 1\nfollows = [1, 0.5]"),
        "list of [joint, coefficient] pairs",
    ),
    _fit(
        "arm-follows-zero",
        _tree("parent = 1", "parent = 1\nfollows = [[1, 0.0]]"),
        "coefficient 0.0 is out of range",
    ),
    _fit(
        "arm-follows-and-transmission",
        _tree("parent = 1", "parent = 1\nfollows = [[1, 0.5]]")
        + "[transmission]\ncoupling = [[1, 0, 0], [0, 1, 0], [0, 0, 1]]\n",
        "follows) and a [transmission] together",
    ),
    _fit(
        "arm-tool-on-no-joint",
        _tree("parent = 3\noffset", "parent = 4\noffset"),
        "tool 2: parent = 4: no such joint",
    ),
    _fit(
        "arm-tool-unknown-field",
        _tree("parent = 3\noffset", "parent = 3\njoint = 3\noffset"),
        "tool 2: unknown field(s) joint",
    ),
    (
        "arm-tool-column-no-such-tool",
        {"a.toml": TREE_TOML, "r.csv": _recording(3)},
        ["fit", "arm-cmm", "{d}/r.csv", "--arm", "{d}/a.toml"],
        2,
        "tool 3, but the arm has 2 tools",
    ),
    (
        "arm-tool-column-serial-arm",
        {"a.toml": _tree("parent = 1", "parent = 2").split("[[tool]]")[0], "r.csv": _recording(2)},
        ["fit", "arm-cmm", "{d}/r.csv", "--arm", "{d}/a.toml"],
        2,
        "tool 2, but the arm has 1 tool",
    ),
    (
        "arm-tool-column-not-whole",
        {"a.toml": TREE_TOML, "r.csv": _recording(1.5)},
        ["discover", "arm-cmm", "{d}/r.csv", "--arm", "{d}/a.toml"],
        2,
        "tool 1.5 is not a tool's number",
    ),
    (
        "run-arm-branched",
        {"a.toml": TREE_TOML},
        ["run", "arm-cmm", "--arm", "{d}/a.toml", "--out", "{d}/o"],
        2,
        "Tree is a branched arm",
    ),
]
