"""What the UAV sees, from a running UAV service: `uvteam demo` on rendered frames serves the UAV's
annotated camera as MJPEG ([uav].annotate_http) and starts `uvteam map --video` on it. A client that
knows nothing of uvteam reads the stream, decodes it with cv2, and finds a red box exactly where a
crowd blob of the UAV's own detections (read from zenoh) is."""

import json
import subprocess
import sys
import threading
import time
from uvteam.io.files import tomllib  # tomli before Python 3.11
import urllib.request
from pathlib import Path

import pytest

from uvteam import keys
from uvteam.bus import BusConfig
from uvteam.io.zenoh_bus import ZenohBus
from uvteam.messages import Detections

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "unit"))
from test_annotate import read_mjpeg, red_fraction  # noqa: E402

pytestmark = pytest.mark.integration


def _wait(pred, timeout_s):
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        got = pred()
        if got:
            return got
        time.sleep(0.2)
    return None


def test_mjpeg_from_the_uav_service_boxes_its_crowd_blobs(tmp_path):
    work = tmp_path / "work"
    demo = subprocess.Popen([sys.executable, "-m", "uvteam", "demo", "--duration", "14", "--quiet", "--seed", "3",
                             "--map-http", "127.0.0.1:0", "--workdir", str(work)],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    dets: dict[int, Detections] = {}
    lock = threading.Lock()
    bus = None
    try:
        head = [demo.stdout.readline() for _ in range(4)]
        endpoint = head[0].split("router ", 1)[1].strip()
        map_url = head[3].split("open ", 1)[1].split()[0]
        uav = tomllib.loads((work / "uav1.toml").read_text())["uav"]
        stream = f"http://{uav['annotate_http']}/stream.mjpg"

        def on_det(_k, d):
            with lock:
                dets[d.frame_seq] = d

        bus = ZenohBus.open(BusConfig(mode="client", connect=(endpoint,), connect_timeout_ms=15000))
        bus.subscribe(keys.key("demo", "uav1", "detections"), Detections, on_det)

        def config():
            try:
                return json.loads(urllib.request.urlopen(map_url + "config.json", timeout=2).read())
            except OSError:
                return None
        cfg = _wait(config, 30)
        assert cfg is not None and cfg["video"] == stream            # the map shows it beside the map

        def up():
            try:
                urllib.request.urlopen(f"http://{uav['annotate_http']}/", timeout=2).read()
                return True
            except OSError:
                return False
        assert _wait(up, 30)
        best, control, frames = 0.0, 1.0, 0
        end = time.monotonic() + 40
        while time.monotonic() < end and best < 0.9:
            for img in read_mjpeg(stream, 5, timeout=20):
                frames += 1
                with lock:
                    recent = [d for s, d in sorted(dets.items())[-8:]]
                boxes = [b for d in recent for b, u in zip(d.blobs.xyxy_px, d.blobs.ugv) if u == ""]
                for b in boxes:
                    f = red_fraction(img, b)
                    if f > best:
                        best, control = f, red_fraction(img, b, shift=15)
    finally:
        if bus is not None:
            bus.close()
        out, _ = demo.communicate(timeout=120)
    assert demo.returncode == 0, "".join(head) + out
    assert best > 0.9, (best, frames, len(dets))      # a crowd blob of the UAV's detections, boxed in red
    assert control < 0.3                               # and the box is there, not everywhere
    log = (work / "logs" / "uav1.log").read_text()
    assert "what the UAV sees: http://127.0.0.1:" in log and "Traceback" not in log
