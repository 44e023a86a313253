"""Drawing primitives for the figures drawn with OpenCV (camera.png, study.png): text, text read
from bottom to top, round tick steps. Commands whose whole run is short draw with OpenCV, which
they load anyway: a plotting library's import costs more than their work (issue 39)."""

from __future__ import annotations

import numpy as np

from calibench.writing import write_bytes

FONT = 0  # cv2.FONT_HERSHEY_SIMPLEX
INK, GREY = (0, 0, 0), (200, 200, 200)  # BGR


def warm_fonts():
    """Start OpenCV's first text call (its fonts' set-up, about 20 ms) in a thread, so that a
    command's figure does not wait for it; join the returned thread before drawing."""
    import threading

    import cv2

    thread = threading.Thread(target=cv2.getTextSize, args=("0", FONT, 0.45, 1), daemon=True)
    thread.start()
    return thread


def text(img, label: str, xy, scale=0.45, color=INK, anchor="left") -> None:
    """``label`` with its baseline at ``xy`` (x, y) px, anchored left, centre or right."""
    import cv2

    (w, _), _ = cv2.getTextSize(label, FONT, scale, 1)
    x = xy[0] - {"left": 0, "centre": w // 2, "right": w}[anchor]
    cv2.putText(img, label, (int(x), int(xy[1])), FONT, scale, color, 1, cv2.LINE_AA)


def vertical_text(img, label: str, bottom_centre, scale=0.38, anchor="bottom") -> None:
    """``label`` read from bottom to top, centred on x = ``bottom_centre[0]``; its start at y =
    ``bottom_centre[1]`` (``anchor`` "bottom") or its end there ("top")."""
    import cv2

    (w, h), base = cv2.getTextSize(label, FONT, scale, 1)
    tile: np.ndarray = np.full((h + base + 2, w + 2, 3), 255, np.uint8)
    cv2.putText(tile, label, (1, h + 1), FONT, scale, INK, 1, cv2.LINE_AA)
    tile = cv2.rotate(tile, cv2.ROTATE_90_COUNTERCLOCKWISE)
    x0 = int(bottom_centre[0] - tile.shape[1] / 2)
    y0 = int(bottom_centre[1] - (tile.shape[0] if anchor == "bottom" else 0))
    y0c, x0c = max(y0, 0), max(x0, 0)
    part = tile[y0c - y0 :, x0c - x0 :][: img.shape[0] - y0c, : img.shape[1] - x0c]
    img[y0c : y0c + part.shape[0], x0c : x0c + part.shape[1]] = np.minimum(
        img[y0c : y0c + part.shape[0], x0c : x0c + part.shape[1]], part
    )


def tick(top: float) -> float:
    """A round tick step (1, 2 or 5 times a power of ten) giving 3 to 7 ticks up to ``top``."""
    power = 10.0 ** np.floor(np.log10(top / 4))
    return next(m * power for m in (1, 2, 5, 10) if top / (m * power) <= 7)


def write_png(path, img) -> None:
    """``img`` (h, w, 3) BGR as PNG to ``path`` whatever its suffix (a temporary name), or
    OSError."""
    import cv2

    ok, buf = cv2.imencode(".png", img)
    if not ok:
        raise OSError(f"cannot encode {path}")
    write_bytes(path, buf.tobytes())
