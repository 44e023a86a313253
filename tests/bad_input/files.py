"""The files the bad-input cases are made of: good recordings and arm files to spoil."""

from __future__ import annotations

from pathlib import Path

import numpy as np

STAGE_HEAD = "x_cmd_mm,y_cmd_mm,x_meas_mm,y_meas_mm"
UR10_TOML = (Path(__file__).resolve().parents[2] / "scenes" / "arms" / "ur10.toml").read_text()
UR10_Q = ["q1_deg", "q2_deg", "q3_deg", "q4_deg", "q5_deg", "q6_deg"]


def stage_csv(n=6, err=lambda x, y: (1e-3 * x, 2e-3 * y), extra=""):
    """A grid of n x n stations with a small smooth error: a good recording to spoil."""
    rows = [STAGE_HEAD + extra]
    for x in np.linspace(0, 500, n):
        for y in np.linspace(0, 400, n):
            ex, ey = err(x, y)
            rows.append(f"{x:g},{y:g},{x + ex:.6f},{y + ey:.6f}")
    return "\n".join(rows) + "\n"


def arm_rows(n=60, seed=0, n_joints=6):
    """Postures spread over the workspace and plausible tracker points (mm); not a calibration
    truth, only well-formed data for the cases to spoil."""
    rng = np.random.default_rng(seed)
    q = rng.uniform(-170, 170, (n, n_joints))
    xyz = rng.uniform(-900, 900, (n, 3)) + [2000, -500, 300]
    return q, xyz


def arm_csv(q, xyz, header=None):
    """The CSV text of postures q (n, joints) in degrees and tracker points xyz (n, 3) in mm."""
    head = header or ",".join(
        [f"q{j + 1}_deg" for j in range(q.shape[1])] + ["x_mm", "y_mm", "z_mm"]
    )
    body = "\n".join(",".join(f"{v:.6f}" for v in row) for row in np.hstack([q, xyz]))
    return head + "\n" + body + "\n"


def arm_csv_with(columns: str, cells: str):
    """A writer of the well-formed arm recording with ``columns`` added to its header and
    ``cells`` to every row (a column of one spoiled value, say)."""

    def write(path):
        head, *rows = arm_csv(*arm_rows()).splitlines()
        path.write_text("\n".join([f"{head},{columns}"] + [f"{r},{cells}" for r in rows]) + "\n")

    return write


ARM_TOML = """name = "Two"
convention = "dh"
[[joint]]
a_mm = 300.0
d_mm = 100.0
alpha_deg = 90.0
theta_deg = 0.0
[[joint]]
a_mm = 250.0
d_mm = 0.0
alpha_deg = 0.0
theta_deg = 0.0
"""
