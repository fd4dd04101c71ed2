"""Make docs/map.png from a real run: `uvteam demo` on loopback, `uvteam map` against its router, and a
headless Chromium screenshot of the page.

    .venv/bin/python docs/make_map_png.py [--after-s 16] [--out docs/map.png]

Needs Debian's chromium (/usr/bin/chromium) and playwright (the test extras); downloads nothing.
"""

from __future__ import annotations

import argparse
import os
import re
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync"]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--after-s", type=float, default=16.0, help="seconds of the demo before the screenshot")
    ap.add_argument("--out", default=str(Path(__file__).resolve().parent / "map.png"))
    ap.add_argument("--chromium", default="/usr/bin/chromium")
    args = ap.parse_args()
    from playwright.sync_api import sync_playwright  # noqa: PLC0415

    uvteam = [sys.executable, "-m", "uvteam"]
    demo = subprocess.Popen([*uvteam, "demo", "--duration", str(args.after_s + 10)], stdout=subprocess.PIPE,
                            text=True, start_new_session=True)
    mp = None
    try:
        first = demo.stdout.readline()
        endpoint = re.search(r"router (tcp/\S+);", first).group(1)
        with socket.socket() as s:
            s.bind(("127.0.0.1", 0))
            port = s.getsockname()[1]
        mp = subprocess.Popen([*uvteam, "map", "--team", "demo", "--connect", endpoint, "--http", f"127.0.0.1:{port}"],
                              stdout=subprocess.PIPE, text=True, start_new_session=True)
        url = mp.stdout.readline().split(" on ")[-1].strip()
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=args.chromium, args=FLAGS)
            page = browser.new_page(viewport={"width": 1400, "height": 860})
            page.goto(url)
            time.sleep(args.after_s)
            page.screenshot(path=args.out)
            browser.close()
        print(f"wrote {args.out}")
    finally:
        for proc in (mp, demo):
            if proc is not None and proc.poll() is None:
                os.killpg(proc.pid, signal.SIGINT)
                proc.wait(timeout=30)
    return 0


if __name__ == "__main__":
    sys.exit(main())
