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
