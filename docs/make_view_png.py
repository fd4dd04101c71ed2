"""Make docs/map-video.png and docs/uav-view.jpg from a real run: `uvteam demo` (which starts `uvteam map
--video` on the UAV service's annotated MJPEG), a headless Chromium screenshot of the map page, and one
frame of the MJPEG stream as the stream sends it.

    .venv/bin/python docs/make_view_png.py [--after-s 14]

Needs Debian's chromium (/usr/bin/chromium) and playwright (the test extras); downloads nothing.
"""

from __future__ import annotations

import argparse
import os
import signal
import subprocess
import sys
import tempfile
import time
from uvteam.io.files import tomllib  # tomli before Python 3.11
import urllib.request
from pathlib import Path

FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync"]
DOCS = Path(__file__).resolve().parent


def one_jpeg(stream_url: str) -> bytes:
    with urllib.request.urlopen(stream_url, timeout=20) as r:
        while True:
            line = r.readline().strip()
            if line.lower().startswith(b"content-length:"):
                n = int(line.split(b":")[1])
                r.readline()
                return r.read(n)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--after-s", type=float, default=14.0, help="seconds of the demo before the screenshot")
    ap.add_argument("--chromium", default="/usr/bin/chromium")
    args = ap.parse_args()
    from playwright.sync_api import sync_playwright  # noqa: PLC0415

    work = Path(tempfile.mkdtemp(prefix="uvteam-docs-"))
    demo = subprocess.Popen([sys.executable, "-m", "uvteam", "demo", "--duration", str(args.after_s + 10),
                             "--map-http", "127.0.0.1:0", "--workdir", str(work)],
                            stdout=subprocess.PIPE, text=True, start_new_session=True)
    try:
        head = [demo.stdout.readline() for _ in range(4)]
        url = head[3].split("open ", 1)[1].split()[0]
        stream = "http://" + tomllib.loads((work / "uav1.toml").read_text())["uav"]["annotate_http"] + "/stream.mjpg"
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=args.chromium, args=FLAGS)
            page = browser.new_page(viewport={"width": 1600, "height": 800})
            time.sleep(2.0)
            page.goto(url)
            time.sleep(args.after_s)
            (DOCS / "uav-view.jpg").write_bytes(one_jpeg(stream))
            page.screenshot(path=str(DOCS / "map-video.png"))
            browser.close()
        print(f"wrote {DOCS / 'map-video.png'} and {DOCS / 'uav-view.jpg'}")
    finally:
        if demo.poll() is None:
            os.killpg(demo.pid, signal.SIGINT)
            demo.wait(timeout=60)
    return 0


if __name__ == "__main__":
    sys.exit(main())
