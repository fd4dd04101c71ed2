"""The UGV service with a forward camera: HOG people detection geolocated by the triangle rule, on the bus.

The camera is OpenCV's vtest.avi (a real pedestrian scene, ../shared/data); the vehicle's autopilot is
the simulator's, over MAVLink on loopback, heading east.
"""

import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from uvteam import keys
from uvteam.bus import BusConfig
from uvteam.io.zenoh_bus import ZenohBus
from uvteam.geo import LocalFrame
from uvteam.messages import PeopleSeen, Status
from uvteam_sim.autopilot import SimAutopilot

pytestmark = pytest.mark.integration
VTEST = Path(__file__).resolve().parents[3] / "shared" / "data" / "pedestrians_static_opencv" / "vtest.avi"
LAT, LON = 31.4850, -111.5440


@pytest.mark.skipif(not VTEST.is_file(), reason="../shared/data not present")
def test_ugv_publishes_geolocated_people(tmp_path, tcp_port, udp_port):
    endpoint = f"tcp/127.0.0.1:{tcp_port}"
    cfg = tmp_path / "ugv1.toml"
    cfg.write_text(f'[vehicle]\nteam = "pp"\nid = "ugv1"\nrole = "ugv"\n\n[bus]\nmode = "client"\nconnect = ["{endpoint}"]\n\n'
                   f'[autopilot]\nurl = "udpin:127.0.0.1:{udp_port}"\nsystem_id = 11\n\n'
                   f'[ugv]\nteam_ugvs = ["ugv1"]\ncamera = "{VTEST}"\ncamera_hfov_deg = 60.0\npeople_rate_hz = 10.0\n')
    bus = ZenohBus.open(BusConfig(mode="peer", listen=(endpoint,)))
    got, status = [], []
    bus.subscribe(keys.key("pp", "ugv1", "people"), PeopleSeen, lambda k, m: got.append(m))
    bus.subscribe(keys.key("pp", "ugv1", "status"), Status, lambda k, m: status.append(m))
    ap = SimAutopilot("127.0.0.1", udp_port, 11, boot_unix_s=time.time() - 5.0).start()
    stop = threading.Event()

    def feed():
        while not stop.is_set():
            ap.send_position(time.time(), LAT, LON, 1300.0, 0.0, 90.0, 0.0, 0.0, 0.5)
            stop.wait(0.1)

    th = threading.Thread(target=feed, daemon=True)
    th.start()
    proc = subprocess.Popen([sys.executable, "-m", "uvteam", "ugv", "--config", str(cfg)],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    try:
        end = time.time() + 40
        while time.time() < end and sum(len(m.people) for m in got) < 30:
            time.sleep(0.2)
    finally:
        proc.terminate()
        out = proc.communicate(timeout=10)[0].decode(errors="replace")
        stop.set()
        th.join(timeout=2)
        ap.stop()
        bus.close()
    assert proc.returncode == 0, out[-2000:]
    people = [p for m in got for p in m.people]
    assert len(people) >= 30, out[-2000:]
    frame = LocalFrame(LAT, LON)
    e, n = frame.wgs84_to_ground(np.array([p.lat_deg for p in people]), np.array([p.lon_deg for p in people]))
    d = np.hypot(e, n)
    # the people are in front (east, 60 deg field of view) at the distances the triangle rule gives
    np.testing.assert_allclose(d, [p.distance_m for p in people], rtol=1e-3, atol=0.05)
    assert np.all((np.array([p.bearing_deg for p in people]) > 90 - 31) & (np.array([p.bearing_deg for p in people]) < 90 + 31))
    assert np.all(e > 0) and 2.0 < np.median(d) < 40.0
    assert all(m.stamp_s > 0 for m in got)
    assert any(s.metrics.get("people_seen", 0) > 0 for s in status)
