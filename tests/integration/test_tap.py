"""`uvteam tap` as a laptop would run it, against a real zenoh session on loopback."""

import json
import subprocess
import sys
import threading
import time

import pytest

from uvteam import keys
from uvteam.bus import BusConfig
from uvteam.io.zenoh_bus import ZenohBus
from uvteam.messages import Crowd, Crowds, Fix, Frame, Status

pytestmark = pytest.mark.integration
TEAM = "tapt"


@pytest.fixture
def team_bus(tcp_port):
    endpoint = f"tcp/127.0.0.1:{tcp_port}"
    bus = ZenohBus.open(BusConfig(mode="peer", listen=(endpoint,)))
    stop = threading.Event()
    bus.declare_alive(keys.alive(TEAM, "ugv1"))
    bus.declare_alive(keys.alive(TEAM, "uav1"))
    crowd = Crowd(3, 31.4851, -111.5441, (31.4851,) * 4, (-111.5441,) * 4, 1.2, -0.4, 0.9, "exact", 0)

    def pump():
        k = 0
        while not stop.is_set():
            now = time.time()
            bus.publish(keys.key(TEAM, "ugv1", "fix"), Fix("ugv1", now - 0.2, 31.485, -111.544, 1300.0, 90.0, 0.5))
            bus.publish(keys.key(TEAM, "ugv1", "status"), Status("ugv1", "ugv", now, "up", 4, k, k,
                                                                 {"crowds_received": 7.0}, "on station"))
            bus.publish(keys.key(TEAM, "loc1", "crowds"), Crowds("loc1", "uav1", now, "exact", ("ugv1",), (), (crowd,)))
            bus.publish(keys.key(TEAM, "uav1", "frame"), Frame("uav1", now, k, 2, 1, "bgr8", b"\x00" * 6))
            bus.put_raw(keys.key(TEAM, "ugv1", "plan"), b"\xc1 not msgpack")
            k += 1
            stop.wait(0.1)

    th = threading.Thread(target=pump, daemon=True)
    th.start()
    yield endpoint
    stop.set()
    th.join(timeout=2)
    bus.close()


def _tap(*args, timeout=30):
    return subprocess.run([sys.executable, "-m", "uvteam", "tap", *args], capture_output=True, text=True, timeout=timeout)


def test_tap_summary_table(team_bus):
    r = _tap("--summary", "--team", TEAM, "--connect", team_bus, "--duration", "3.5")
    assert r.returncode == 0, r.stderr
    table = r.stdout.split("uvteam tap --summary")[-1]        # the last redraw
    rows = {line.split()[0]: line for line in table.splitlines() if line.startswith(("ugv1", "uav1"))}
    ugv1 = rows["ugv1"].split()
    assert ugv1[1] == "yes"                                    # alive (liveliness token)
    assert 0.1 <= float(ugv1[2]) < 1.5                         # fix age: published 0.2 s after capture
    assert 15 <= float(ugv1[3]) <= 25                          # fix + status, 10 Hz each (bad plans not counted)
    assert ugv1[4] == "up" and ugv1[5] == "4"                  # link, the service's own rejected count
    assert "on station" in rows["ugv1"] and "crowds_received=7" in table   # the note, then the metrics
    assert rows["uav1"].split()[1] == "yes"
    assert float(rows["uav1"].split()[3]) == 0.0               # its 10 Hz frames are not pulled by default
    assert "crowd 3: 31.485100, -111.544100  r95 0.90 m  exact" in table
    bad = int(table.split("undecodable here:")[1].split()[0])
    assert bad >= 10                                           # the garbage plans, counted here too
    assert "rejected uvteam/tapt/ugv1/plan" in r.stderr


def test_tap_json_lines(team_bus):
    r = _tap(f"uvteam/{TEAM}/*/fix", "--connect", team_bus, "--count", "3")
    assert r.returncode == 0, r.stderr
    lines = [json.loads(x) for x in r.stdout.splitlines()]
    assert len(lines) >= 3 and all(x["key"] == f"uvteam/{TEAM}/ugv1/fix" and x["lat_deg"] == 31.485 for x in lines)
    r = _tap(f"uvteam/{TEAM}/uav1/frame", "--connect", team_bus, "--count", "1")
    assert json.loads(r.stdout.splitlines()[0])["data"] == "<6 bytes>"   # pixels are not dumped as text
