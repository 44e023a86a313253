"""study.png: each parameter's normalised errors against N(0, 1), and its coverage.

Drawn with OpenCV: importing a plotting library costs a third of a second on 2 cores, a third of
a fast study's whole fixed cost (issue 39).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from calibench.scenarios import cvplot
from calibench.scenarios.study.summary import coverage_band, in_band

WIDTH, HEIGHT = 1260, 405  # px
Z_CLIP, BINS = 6.0, 60  # the histogram spans +-Z_CLIP std in BINS bins
BLUE, GREEN, RED = (180, 119, 31), (44, 160, 44), (40, 39, 214)  # BGR
BAND = (215, 215, 215)


def _axes(img, box, ticks_y, fmt) -> None:
    """A panel's frame ``box`` (x0, y0, x1, y1) px, with y ticks ``ticks_y``: (value, y px)."""
    import cv2

    x0, y0, x1, y1 = box
    cv2.rectangle(img, (x0, y0), (x1, y1), cvplot.INK, 1)
    for v, y in ticks_y:
        cv2.line(img, (x0 - 4, y), (x0, y), cvplot.INK, 1)
        cvplot.text(img, fmt(v), (x0 - 7, y + 4), 0.38, anchor="right")


def _histogram(img, box, z: np.ndarray, title: str) -> None:
    """The normalised errors ``z`` (k,) as a density histogram (clipped to +-Z_CLIP) with the
    standard normal density over it."""
    import cv2

    x0, y0, x1, y1 = box
    edges = np.linspace(-Z_CLIP, Z_CLIP, BINS + 1)
    dens = (
        np.histogram(np.clip(z, -Z_CLIP, Z_CLIP), edges, density=True)[0] if len(z) else np.zeros(0)
    )
    top = 1.1 * max(float(np.max(dens, initial=0.0)), 1 / math.sqrt(2 * math.pi))

    def px(x, y):
        return (
            int(round(x0 + (x1 - x0) * (x + Z_CLIP) / (2 * Z_CLIP))),
            int(round(y1 - (y1 - y0) * y / top)),
        )

    for lo, hi, d in zip(edges[:-1], edges[1:], dens):
        if d > 0:
            cv2.rectangle(img, px(lo, d), px(hi, 0), BLUE, -1)
    x = np.linspace(-Z_CLIP, Z_CLIP, 200)
    curve = np.array([px(a, b) for a, b in zip(x, np.exp(-x * x / 2) / math.sqrt(2 * math.pi))])
    cv2.polylines(img, [curve.astype(np.int32)], False, cvplot.INK, 2, cv2.LINE_AA)
    step = cvplot.tick(top)
    _axes(img, box, [(v, px(0, v)[1]) for v in np.arange(0, top, step)], lambda v: f"{v:.2g}")
    for v in range(-int(Z_CLIP), int(Z_CLIP) + 1, 2):
        cv2.line(img, (px(v, 0)[0], y1), (px(v, 0)[0], y1 + 4), cvplot.INK, 1)
        cvplot.text(img, f"{v}", (px(v, 0)[0], y1 + 18), 0.38, anchor="centre")
    cvplot.text(img, "normalised error", ((x0 + x1) // 2, y1 + 36), 0.42, anchor="centre")
    cvplot.text(img, title, ((x0 + x1) // 2, y0 - 10), 0.5, anchor="centre")
    cv2.rectangle(img, (x0 + 12, y0 + 12), (x0 + 32, y0 + 24), BLUE, -1)
    cvplot.text(img, "(estimate - truth) / std", (x0 + 40, y0 + 23), 0.4)
    cv2.line(img, (x0 + 12, y0 + 38), (x0 + 32, y0 + 38), cvplot.INK, 2, cv2.LINE_AA)
    cvplot.text(img, "N(0, 1): an honest std", (x0 + 40, y0 + 42), 0.4)


def _coverage(img, box, names: list, cover: list, bands: list, trials: int) -> None:
    """Each parameter's coverage of its +-1.96 std interval as a bar, green inside its band
    (summary.json's ``coverage_95_expected``, judged by the summary's own rule), red outside; the
    band drawn and labelled is the first's (every parameter counts the same ``trials``)."""
    import cv2

    x0, y0, x1, y1 = box
    lo, hi = bands[0] if bands else coverage_band(trials)

    def y(v):
        return int(round(y1 - (y1 - y0) * v / 1.05))

    cv2.rectangle(img, (x0 + 1, y(hi)), (x1 - 1, y(lo)), BAND, -1)
    step = (x1 - x0) / max(len(names), 1)
    for k, (name, c, band) in enumerate(zip(names, cover, bands)):
        left = int(x0 + (k + 0.1) * step)
        right = max(int(x0 + (k + 0.9) * step), left + 1)
        colour = GREEN if in_band(c, band) else RED
        cv2.rectangle(img, (left, y(c)), (right, y1), colour, -1)
        cvplot.vertical_text(img, name, (int(x0 + (k + 0.5) * step), y1 + 4), 0.32, anchor="top")
    for edge in (lo, hi):  # the band's edges over the bars too
        cv2.line(img, (x0, y(edge)), (x1, y(edge)), (90, 90, 90), 1)
    _axes(img, box, [(v, y(v)) for v in np.arange(0.0, 1.01, 0.2)], lambda v: f"{v:.1f}")
    # the edges are coverages k / trials: digits enough that the next coverage in (or out) of
    # the band is not printed as the edge itself
    digits = max(2, math.ceil(math.log10(max(trials, 1))))
    cvplot.text(img, "coverage per parameter", ((x0 + x1) // 2, y0 - 24), 0.5, anchor="centre")
    cvplot.text(
        img,
        f"grey {lo:.{digits}f}-{hi:.{digits}f}: 0.95 within {trials} trials' scatter "
        "(red: outside)",
        ((x0 + x1) // 2, y0 - 7),
        0.4,
        anchor="centre",
    )
    cvplot.vertical_text(img, "coverage of +-1.96 std", (x0 - 40, (y0 + y1) // 2), 0.4)


def write_study_figure(path: Path, rows: list[dict], summary: dict) -> None:
    """study.png at ``path``: left, the normalised errors of every parameter with a std, pooled,
    against N(0, 1); right, each parameter's coverage against the band an honest std gives.

    Parameters
    ----------
    path : Path
        Where to write it.
    rows : list of dict
        The trials' journal rows (``<name>.estimate``, ``.truth``, ``.std``, ``ok``).
    summary : dict
        Their summary (:func:`~calibench.scenarios.study.summary.summarise`).
    """
    good = [r for r in rows if r["ok"]]
    with_std = [p for p in summary["parameters"] if p["coverage_95"] is not None]
    keys = [tuple(f"{p['name']}.{x}" for x in ("estimate", "truth", "std")) for p in with_std]
    z = np.array([(r[e] - r[t]) / r[s] for e, t, s in keys for r in good if r.get(s)])
    img = np.full((HEIGHT, WIDTH, 3), 255, np.uint8)
    _histogram(img, (60, 40, 600, 300), z, f"{summary['scenario']}: {len(good)} trials")
    _coverage(
        img,
        (700, 40, 1245, 300),
        [p["name"] for p in with_std],
        [p["coverage_95"] for p in with_std],
        [p["coverage_95_expected"] for p in with_std],
        len(good),
    )
    cvplot.write_png(path, img)
