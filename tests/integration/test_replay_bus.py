"""`uvteam replay` onto a real zenoh bus, under another team id: every recorded payload arrives with its
bytes and zenoh encoding unchanged, liveliness tokens come and go as recorded, and the pace follows
the log times (--speed)."""

import subprocess
import sys
import threading
import time

import pytest
import zenoh

from uvteam.io.recording import read_recording

from conftest import record_experiment

pytestmark = pytest.mark.integration


@pytest.fixture(scope="module")
def recording(tmp_path_factory):
    path = tmp_path_factory.mktemp("replay") / "exp.mcap"
    record_experiment(path, 4, 3.0)
    return path


@pytest.mark.parametrize("speed, at_least_s", [("0", 0.0), ("2", 1.2)])   # as fast as it goes; 3 s at 2x
def test_replay_puts_every_payload_back_as_it_was(recording, tcp_port, speed, at_least_s):
    endpoint = f"tcp/127.0.0.1:{tcp_port}"
    conf = zenoh.Config()
    conf.insert_json5("mode", '"peer"')
    conf.insert_json5("listen/endpoints", f'["{endpoint}"]')
    conf.insert_json5("scouting/multicast/enabled", "false")
    got: list[tuple[str, bytes, str]] = []
    alive: list[tuple[str, bool]] = []
    lock = threading.Lock()
    with zenoh.open(conf) as s:
        def on_sample(smp):
            with lock:
                got.append((str(smp.key_expr), smp.payload.to_bytes(), str(smp.encoding)))

        def on_alive(smp):
            with lock:
                alive.append((str(smp.key_expr), smp.kind == zenoh.SampleKind.PUT))

        s.declare_subscriber("uvteam/rp1/**", on_sample)
        s.liveliness().declare_subscriber("uvteam/rp1/*/alive", on_alive)
        t0 = time.monotonic()
        r = subprocess.run([sys.executable, "-m", "uvteam", "replay", str(recording), "-e", endpoint, "--team", "rp1",
                            "--speed", speed], capture_output=True, text=True, timeout=120)
        took = time.monotonic() - t0
        time.sleep(0.5)
    assert r.returncode == 0, r.stderr
    want = [(rec.key.replace("/exp/", "/rp1/"), rec.data, rec.encoding) for rec in read_recording(recording).records
            if rec.encoding != "alive"]
    with lock:
        assert sorted(got) == sorted(want)                     # every payload, bytes and encoding unchanged
        ups = {k for k, up in alive if up}
    assert {f"uvteam/rp1/{v}/alive" for v in ("loc1", "uav1", "ugv1", "ugv6")} <= ups
    assert took >= at_least_s
