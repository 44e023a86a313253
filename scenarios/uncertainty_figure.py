"""uncertainty.png: the task's standard uncertainty mapped over the workspace, the places where
the GUM framework and the Monte Carlo disagree marked."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from calibench.scenarios.cvplot import INK, text, write_png

SIZE = 640


def _colour(t: float) -> tuple[int, int, int]:
    """Blue (t = 0) to red (t = 1), BGR."""
    t = float(np.clip(t, 0.0, 1.0))
    return (int(255 * (1 - t)), int(80 + 60 * (1 - abs(2 * t - 1))), int(255 * t))


def write_uncertainty_figure(path: Path, points_mm: np.ndarray, result: dict) -> None:
    """Each grid place seen from above (x, y of its point, mm), a disc coloured by its largest u
    over its quantities (Monte Carlo's), its value written beside; a black ring where the GUM
    framework is not validated at one of its quantities (JCGM 101 8)."""
    grid = result["grid"]
    per = len(grid) // len(points_mm)
    u = np.array([g["u"] for g in grid]).reshape(len(points_mm), per).max(axis=1)
    valid = [g["gum_valid"] for g in grid]
    bad = [not all(valid[k * per : (k + 1) * per]) for k in range(len(points_mm))]
    img = np.full((SIZE + 80, SIZE, 3), 255, np.uint8)
    xy = np.asarray(points_mm, float)[:, :2]
    lo, hi = xy.min(axis=0), xy.max(axis=0)
    span = max(float(np.max(hi - lo)), 1e-9)
    px = 60 + (xy - lo) / span * (SIZE - 120)
    top = max(float(u.max()), 1e-12)
    for (x, y), ui, b in zip(px, u, bad):
        centre = (int(x), int(SIZE - y))
        cv2.circle(img, centre, 14, _colour(ui / top), -1, cv2.LINE_AA)
        if b:
            cv2.circle(img, centre, 18, INK, 2, cv2.LINE_AA)
        text(img, f"{ui:.2g}", (centre[0] + 20, centre[1] + 5), 0.4)
    unit = result["unit"]
    text(img, f"{result['scenario']}: {result['task']}", (10, 20), 0.45)
    text(
        img,
        f"largest u over each place's quantities ({unit}), {result['trials']} trials, "
        f"{result['stopped']}; ring: GUM not validated",
        (10, SIZE + 40),
        0.4,
    )
    text(img, "x (mm) right, y (mm) up, seen from above", (10, SIZE + 65), 0.4)
    write_png(path, img)


def write_uncertainty_rrd(path: Path, points_mm: np.ndarray, result: dict, png: Path) -> None:
    """The same map in rerun (uncertainty.rrd): each grid place at its point (m), coloured and
    sized by its largest u, in red where the GUM framework is not validated there; the table of
    every quantity and the figure beside."""
    from calibench.scenarios import rrlog

    grid = result["grid"]
    per = len(grid) // len(points_mm)
    u = np.array([g["u"] for g in grid]).reshape(len(points_mm), per).max(axis=1)
    valid = [all(g["gum_valid"] for g in grid[k * per : (k + 1) * per]) for k in range(len(u))]
    top = max(float(u.max()), 1e-12)
    colours = [_colour(v / top)[::-1] for v in u]  # BGR to RGB
    rec = rrlog.open_recording(path, "calibench-uncertainty")
    try:
        pts = np.asarray(points_mm, float) / 1000
        rrlog.log_points3d(rec, "world/uncertainty/u", pts, colours, radius=0.01, static=True)
        bad = pts[[not v for v in valid]]
        if len(bad):
            rrlog.log_points3d(
                rec, "world/uncertainty/gum_not_validated", bad, rrlog.RED, 0.02, True
            )
        unit = result["unit"]
        rows = "\n".join(
            f"| {g['at']} | {g['quantity']} | {g['u']:.3g} | {g['interval_95'][0]:.3g} .. "
            f"{g['interval_95'][1]:.3g} | {g['gum_u']:.3g} | {'yes' if g['gum_valid'] else 'no'} |"
            for g in grid
        )
        table = (
            f"**{result['task']}** ({unit}), {result['trials']} trials, {result['status']}\n\n"
            "| at | quantity | u | 95 % interval | GUM u | GUM validated |\n"
            "|---|---|---|---|---|---|\n" + rows
        )
        rrlog.log_text(rec, "report", table)
        rrlog.log_figure(rec, "figure", png)
    finally:
        rrlog.close(rec)
