"""Screenshots of each scenario's recording in rerun's web viewer, as a user opens it.

``python docs/screenshots.py [OUT_ROOT]``: for every ``OUT_ROOT/<scenario>/run.rrd`` (default
``calibench-out``, what ``make demo`` writes), serve it with ``rerun --serve-web``, open the web
viewer in headless Chromium (Debian's ``chromium``; WebGL through SwiftShader, ``&renderer=webgl``),
wait for the viewer to load and lay out the recording's blueprint, and save
``docs/viewer_<scenario>.png``. Needs ``chromium`` on the PATH and the ``websockets`` package
(DevTools protocol); nothing of this runs in the tests.
"""

from __future__ import annotations

import asyncio
import base64
import contextlib
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

DOCS = Path(__file__).resolve().parent
WAIT_S = 40.0  # the viewer's wasm compiles on the CPU: give it time before the picture
SIZE = (1600, 900)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _wait_http(url: str, timeout: float = 30.0) -> None:
    t0 = time.time()
    while time.time() - t0 < timeout:
        try:
            urllib.request.urlopen(url, timeout=2).read(64)
            return
        except OSError:
            time.sleep(0.3)
    raise RuntimeError(f"nothing answers at {url}")


async def _capture(devtools_port: int, url: str, png: Path) -> None:
    import websockets

    targets = json.loads(urllib.request.urlopen(f"http://127.0.0.1:{devtools_port}/json").read())
    page = next(t for t in targets if t["type"] == "page")
    async with websockets.connect(page["webSocketDebuggerUrl"], max_size=64 * 2**20) as ws:
        ids = iter(range(1, 10**6))

        async def call(method, **params):
            i = next(ids)
            await ws.send(json.dumps({"id": i, "method": method, "params": params}))
            while True:
                msg = json.loads(await ws.recv())
                if msg.get("id") == i:
                    return msg.get("result", {})

        await call(
            "Emulation.setDeviceMetricsOverride",
            width=SIZE[0],
            height=SIZE[1],
            deviceScaleFactor=1,
            mobile=False,
        )
        await call("Page.navigate", url=url)
        await asyncio.sleep(WAIT_S)
        shot = await call("Page.captureScreenshot", format="png")
        png.write_bytes(base64.b64decode(shot["data"]))


def screenshot(rrd: Path, png: Path) -> None:
    web, grpc, devtools = _free_port(), _free_port(), _free_port()
    rerun = Path(sys.executable).with_name("rerun")
    # own process groups: `rerun` and `chromium` start children that a plain terminate() would
    # orphan
    server = subprocess.Popen(
        [str(rerun), "--serve-web", "--web-viewer-port", str(web), "--port", str(grpc), str(rrd)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,
    )
    browser = subprocess.Popen(
        [
            shutil.which("chromium") or "chromium",
            "--headless=new",
            "--no-sandbox",
            "--use-angle=swiftshader",
            "--enable-unsafe-swiftshader",
            "--ignore-gpu-blocklist",
            f"--window-size={SIZE[0]},{SIZE[1]}",
            f"--remote-debugging-port={devtools}",
            "about:blank",
        ],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        start_new_session=True,
    )
    try:
        _wait_http(f"http://127.0.0.1:{web}")
        _wait_http(f"http://127.0.0.1:{devtools}/json/version")
        proxy = f"rerun%2Bhttp%3A%2F%2F127.0.0.1%3A{grpc}%2Fproxy"
        asyncio.run(_capture(devtools, f"http://127.0.0.1:{web}/?url={proxy}&renderer=webgl", png))
    finally:
        for proc in (browser, server):
            with contextlib.suppress(ProcessLookupError):
                os.killpg(proc.pid, signal.SIGTERM)
            proc.wait(10)


def main() -> None:
    root = Path(sys.argv[1]) if len(sys.argv) > 1 else Path("calibench-out")
    for rrd in sorted(root.glob("*/run.rrd")):
        png = DOCS / f"viewer_{rrd.parent.name}.png"
        screenshot(rrd, png)
        print(f"{rrd} -> {png}")


if __name__ == "__main__":
    main()
