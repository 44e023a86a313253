"""camera.png: how well each photo fits the calibration, and where in the image the corners lie
(a calibration knows the lens only where the board went: corners missing from the image's edges
leave its distortion there a guess)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

COVERAGE_GRID = 8  # the image cut into 8 x 8 cells for the coverage figure
# below this share of the cells the console says to add photos near the edges (the usual advice:
# the board should reach every part of the image across the photos)
COVERAGE_WARN = 0.5


def coverage(corners: dict, size: tuple[int, int]) -> float:
    """Share of the image's COVERAGE_GRID x COVERAGE_GRID cells that hold at least one corner.

    Parameters
    ----------
    corners : dict of str to ndarray
        Each photo's corners, (n_corners, 2) px (NaN where left out).
    size : (width, height) px
    """
    pts = np.concatenate([np.asarray(c) for c in corners.values()]) if corners else np.zeros((0, 2))
    pts = pts[np.isfinite(pts).all(axis=1)]
    cells = np.floor(pts / np.asarray(size, float) * COVERAGE_GRID).astype(int)
    cells = cells[((cells >= 0) & (cells < COVERAGE_GRID)).all(axis=1)]
    return len({tuple(c) for c in cells}) / COVERAGE_GRID**2


def write_camera_figure(path: Path, result: dict, corners: dict) -> None:
    """Left: the RMS reprojection error of each photo used, with the whole calibration's; right:
    every corner used, in the image's pixels, coloured by photo, and the coverage."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    w, h = result["image_size"]
    per_view = result["per_view_rms_px"]
    f, (a, b) = plt.subplots(1, 2, figsize=(13, 4.8), constrained_layout=True)
    names = list(per_view)
    a.bar(range(len(names)), [per_view[n] for n in names], color="tab:blue")
    a.axhline(result["rms_px"], color="k", ls="--", label=f"all photos {result['rms_px']:.3f} px")
    a.set_xticks(range(len(names)), names, rotation=60, ha="right", fontsize=7)
    a.set(ylabel="RMS reprojection error (px)", title="each photo's fit")
    a.legend()
    cmap = plt.get_cmap("viridis")
    for k, c in enumerate(corners.values()):
        c = np.asarray(c)
        b.plot(c[:, 0], c[:, 1], ".", ms=3, color=cmap(k / max(len(corners) - 1, 1)))
    b.add_patch(plt.Rectangle((-0.5, -0.5), w, h, fill=False, color="k"))
    b.set(
        xlim=(-0.03 * w, 1.03 * w),
        ylim=(1.03 * h, -0.03 * h),
        aspect="equal",
        xlabel="u (px)",
        ylabel="v (px)",
        title=f"where the corners lie: {coverage(corners, (w, h)):.0%} of the image's "
        f"{COVERAGE_GRID} x {COVERAGE_GRID} cells",
    )
    f.suptitle(
        f"{len(names)} photos, {w} x {h}: fx {result['K'][0][0]:.1f}, fy {result['K'][1][1]:.1f} "
        "px; " + ", ".join(f"{k} {v:+.4g}" for k, v in result["distortion"].items())
    )
    f.savefig(path, dpi=80)
    plt.close(f)
