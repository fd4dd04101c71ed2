"""A cut link between two hosts: the router and a subscriber in one network namespace, a vehicle
publishing its fix in another, a veth between them. The link goes down for 6 s (past the 3 s lease:
the session is declared dead) and comes back; the vehicle's fix reaches the subscriber again within
2 s. Needs root and iproute2 (network namespaces made by the test itself); skips saying so elsewhere."""

import os
import shutil
import subprocess
import sys
import time
import uuid

import pytest

pytestmark = pytest.mark.integration

PUB = """
import sys, time
from uvteam import keys
from uvteam.bus import BusConfig
from uvteam.io.zenoh_bus import ZenohBus
from uvteam.messages import Fix
with ZenohBus.open(BusConfig(mode="client", connect=(sys.argv[1],))) as bus:
    while True:
        bus.publish(keys.key("p", "ugv1", "fix"), Fix("ugv1", time.time(), 31.485, -111.544, 1300.0, 90.0, 0.5))
        time.sleep(0.05)
"""
SUB = """
import sys, time
from uvteam import keys
from uvteam.bus import BusConfig
from uvteam.io.zenoh_bus import ZenohBus
from uvteam.messages import Fix
with ZenohBus.open(BusConfig(mode="client", connect=(sys.argv[1],))) as bus:
    bus.subscribe(keys.key("p", "ugv1", "fix"), Fix, lambda k, m: print(f"{time.time():.3f}", flush=True))
    while True:
        time.sleep(1)
"""


def _ip(*args):
    return subprocess.run(["ip", *args], capture_output=True, text=True)


@pytest.fixture
def two_hosts():
    if os.geteuid() != 0 or shutil.which("ip") is None:
        pytest.skip("needs root and iproute2 to make network namespaces for a cut-link test")
    tag = uuid.uuid4().hex[:6]
    a, b, va, vb = f"uvA{tag}", f"uvB{tag}", f"uva{tag}", f"uvb{tag}"
    if _ip("netns", "add", a).returncode != 0:
        pytest.skip(f"cannot make network namespaces here: {_ip('netns', 'add', a).stderr.strip()}")
    _ip("netns", "add", b)
    try:
        for cmd in (["link", "add", va, "type", "veth", "peer", "name", vb], ["link", "set", va, "netns", a],
                    ["link", "set", vb, "netns", b], ["-n", a, "addr", "add", "10.77.0.1/24", "dev", va],
                    ["-n", b, "addr", "add", "10.77.0.2/24", "dev", vb], ["-n", a, "link", "set", va, "up"],
                    ["-n", b, "link", "set", vb, "up"], ["-n", a, "link", "set", "lo", "up"],
                    ["-n", b, "link", "set", "lo", "up"]):
            r = _ip(*cmd)
            if r.returncode != 0:
                pytest.skip(f"cannot set up veth between namespaces: ip {' '.join(cmd)}: {r.stderr.strip()}")
        yield a, b, vb
    finally:
        _ip("netns", "del", a)
        _ip("netns", "del", b)


def test_a_cut_link_heals_and_the_fix_flows_again_within_2_s(two_hosts):
    a, b, vb = two_hosts
    endpoint = "tcp/10.77.0.1:17447"
    py = sys.executable
    procs = []

    def run_in(ns, *args, **kw):
        p = subprocess.Popen(["ip", "netns", "exec", ns, py, *args], start_new_session=True, **kw)
        procs.append(p)
        return p

    try:
        run_in(a, "-m", "uvteam", "router", "--listen", endpoint, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        time.sleep(2.0)
        sub = run_in(a, "-c", SUB, endpoint, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
        run_in(b, "-c", PUB, endpoint, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        got = []
        import threading

        threading.Thread(target=lambda: [got.append(float(x)) for x in sub.stdout], daemon=True).start()
        end = time.time() + 15
        while time.time() < end and len(got) < 20:
            time.sleep(0.1)
        assert len(got) >= 20, "no fixes across the veth before the cut"
        assert _ip("-n", b, "link", "set", vb, "down").returncode == 0
        time.sleep(6.0)
        before = len(got)
        assert _ip("-n", b, "link", "set", vb, "up").returncode == 0
        healed = time.time()
        end = healed + 10
        while time.time() < end and not [t for t in got[before:] if t > healed]:
            time.sleep(0.05)
        back = [t for t in got[before:] if t > healed]
        assert back, "the fix never flowed again"
        print(f"fix back {back[0] - healed:.2f} s after the link came up")
        assert back[0] - healed <= 2.0
    finally:
        for p in procs:
            try:
                os.killpg(p.pid, 15)
                p.wait(timeout=5)
            except Exception:
                pass
