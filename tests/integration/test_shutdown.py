"""A service stops cleanly even when one of its threads is late: nothing is inside zenoh at interpreter exit.

A Python thread still inside a zenoh call (pyo3, Rust) when the interpreter finalises is cancelled through
native frames that catch the unwind, and glibc aborts the process ("FATAL: exception not rethrown"): a UGV
service that had logged its clean stop died of SIGABRT once in CI (its mission exchange, retrying an
autopilot gone quiet for up to 3 s, could outlive the 2 s join). Each test runs a real process; on the code
before the fix the first one's thread dies of "session closed" and the second one's process aborts (-6).
"""

import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

from uvteam.io.ports import free_port

ROOT = Path(__file__).resolve().parents[2]


def _run(code: str, *args: str, stop_after_s: float | None = None, timeout_s: float = 30.0):
    proc = subprocess.Popen([sys.executable, "-c", textwrap.dedent(code), *args], cwd=ROOT,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if stop_after_s is not None:
        time.sleep(stop_after_s)
        proc.send_signal(signal.SIGTERM)
    out, err = proc.communicate(timeout=timeout_s)
    return proc.returncode, out, err


def test_a_publish_after_the_bus_closed_never_reaches_zenoh():
    code = """
        import sys, threading, time
        from uvteam.bus import BusConfig
        from uvteam.io.zenoh_bus import ZenohBus
        from uvteam.messages import Status

        bus = ZenohBus.open(BusConfig(listen=(sys.argv[1],)))
        msg = Status("loc1", "localizer", 1.0, "none", 0, 0, 0, {}, "")

        def loop():                  # a thread that outlives the bus, publishing as fast as it can
            while True:
                bus.publish("uvteam/t/loc1/status", msg)

        threading.Thread(target=loop, daemon=True).start()
        time.sleep(0.3)
        bus.close()
        time.sleep(0.1)
        print("dropped_closed", bus.dropped_closed, flush=True)
    """
    rc, out, err = _run(code, f"tcp/127.0.0.1:{free_port()}")
    assert rc == 0, err[-2000:]
    assert int(out.split()[-1]) > 0


def test_a_service_whose_worker_ignores_the_stop_still_exits_cleanly(tmp_path):
    """run_node joins its threads for 2 s; one still in zenoh after that is named, and service_main
    exits without finalising the interpreter (everything is closed by then)."""
    code = """
        import sys
        from uvteam.service import run_node, service_main

        class Stubborn:
            service = "localizer"

            def __init__(self, bus):
                self.bus = bus

            def start(self): pass
            def step(self, timeout_s): pass
            def metrics(self): return {}
            def link_state(self): return "none"
            def note(self): return ""

            def workers(self):
                def stubborn(stop):      # ignores the stop, and keeps calling into zenoh
                    while True:
                        try:
                            self.bus.session.info.zid()
                        except Exception:
                            pass
                return [("stubborn", stubborn)]

        sys.exit(service_main(sys.argv[1:], "stubborn", "test", "localizer",
                              lambda cfg, stop: run_node(cfg, stop, Stubborn)))
    """
    cfg = tmp_path / "loc1.toml"
    cfg.write_text('[vehicle]\nteam = "t"\nid = "loc1"\nrole = "localizer"\n\n'
                   '[localizer]\nuav = "uav1"\nugvs = ["ugv1", "ugv2", "ugv3", "ugv4"]\n')
    rc, out, err = _run(code, "--config", str(cfg), "--listen", f"tcp/127.0.0.1:{free_port()}", stop_after_s=2.0)
    assert rc == 0, err[-2000:]
    assert "still running 2 s after the stop: stubborn" in err
    assert "stopping" in err


def test_a_publish_racing_close_is_a_counted_drop_not_an_error():
    """A publisher that passed the closed check as another thread closed the bus: zenoh raises
    "session closed" inside the put; the bus counts it as a drop (it raised on the code before)."""
    code = """
        import sys
        from uvteam.bus import BusConfig
        from uvteam.io.zenoh_bus import ZenohBus
        from uvteam.messages import Status

        bus = ZenohBus.open(BusConfig(listen=(sys.argv[1],)))
        real = bus.session

        class ClosesFirst:           # the other thread's close() lands between the check and the put
            def __getattr__(self, name):
                return getattr(real, name)

            def declare_publisher(self, *a, **kw):
                bus.close()
                return real.declare_publisher(*a, **kw)

            def put(self, *a, **kw):
                bus.close()
                return real.put(*a, **kw)

        bus.session = ClosesFirst()
        bus.publish("uvteam/t/loc1/status", Status("loc1", "localizer", 1.0, "none", 0, 0, 0, {}, ""))
        bus._closed = False
        bus.put_raw("uvteam/t/loc1/status", b"x")
        print("dropped_closed", bus.dropped_closed, "published", bus.published, flush=True)
    """
    rc, out, err = _run(code, f"tcp/127.0.0.1:{free_port()}")
    assert rc == 0, err[-2000:]
    assert out.split()[-4:] == ["dropped_closed", "2", "published", "0"], out
