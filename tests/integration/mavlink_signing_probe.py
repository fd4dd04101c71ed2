"""Run by test_mavlink_hardening.py in a fresh interpreter (MAVLINK20 unset, as on a vehicle whose
service was started without it): an AutopilotLink with a signing key talks over TCP or a serial pty,
through a relay, to a SimAutopilot that signs with the same key, another key, or not at all.
Prints one JSON line: {"case", "state", "link_up", "uploaded"}.

One case per process: pymavlink's mavutil sets MAVLINK20 in os.environ itself the first time it meets a
MAVLink 2 byte, so a second link in the same process would not show what a fresh service does.

    python mavlink_signing_probe.py tcp|serial "same key"|"autopilot unsigned"|"wrong key"
"""

import json
import os
import socket
import sys
import threading
import time

from uvteam.autopilot import MissionItem, mavlink2
from uvteam.errors import LinkError
from uvteam.io.mavlink import AutopilotLink
from uvteam.io.ports import free_port
from uvteam_sim.autopilot import SimAutopilot

KEY = bytes(range(32))
CASES = {"same key": KEY, "autopilot unsigned": None, "wrong key": bytes(32)}


class Relay:
    """Byte stream <-> the SimAutopilot's UDP side, one MAVLink packet per datagram each way."""

    def __init__(self, read, write, udp_port):
        self.read, self.write = read, write
        self.udp = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.udp.bind(("127.0.0.1", udp_port))
        self.udp.settimeout(0.05)
        self.ap_addr = None
        self.stop = threading.Event()
        self.parser = mavlink2.MAVLink(None)
        self.parser.robust_parsing = True
        self.threads = [threading.Thread(target=f, daemon=True) for f in (self._down, self._up)]
        for t in self.threads:
            t.start()

    def _down(self):
        while not self.stop.is_set():
            try:
                data, self.ap_addr = self.udp.recvfrom(4096)
            except OSError:
                continue
            try:
                self.write(data)
            except OSError:
                return

    def _up(self):
        while not self.stop.is_set():
            try:
                data = self.read()
            except (TimeoutError, BlockingIOError):
                continue
            except OSError:
                return
            if not data:
                time.sleep(0.01)
                continue
            for m in self.parser.parse_buffer(data) or []:
                if self.ap_addr is not None and m.get_type() != "BAD_DATA":
                    self.udp.sendto(m.get_msgbuf(), self.ap_addr)

    def close(self):
        self.stop.set()
        for t in self.threads:
            t.join(timeout=1.0)
        self.udp.close()


def exercise(link, ap):
    for _ in range(15):
        ap.send_position(time.time(), 31.485, -111.544, 1300.0, 0.0, 10.0, 0.0, 0.0, 1.0)
        time.sleep(0.05)
    end = time.monotonic() + 2.5     # the autopilot's heartbeat comes at 1 Hz
    while (link.state() is None or not link.link_up) and time.monotonic() < end:
        time.sleep(0.02)
    out = {"state": link.state() is not None, "link_up": link.link_up, "uploaded": False}
    if out["state"]:
        try:
            link.upload_mission([MissionItem(mavlink2.MAV_CMD_NAV_WAYPOINT, 31.4851, -111.5441, 0.0)],
                                timeout_s=0.3, retries=3)
            out["uploaded"] = len(ap.mission) == 1
        except LinkError:
            pass
    return out


def run_tcp(ap_key):
    tcp_port, udp_port = free_port(socket.SOCK_STREAM), free_port(socket.SOCK_DGRAM)
    srv = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    srv.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    srv.bind(("127.0.0.1", tcp_port))
    srv.listen(1)
    ap = SimAutopilot("127.0.0.1", udp_port, 7, boot_unix_s=time.time() - 5.0, signing_key=ap_key).start()
    link = AutopilotLink(f"tcp:127.0.0.1:{tcp_port}", target_system=7, signing_key=KEY).start()
    srv.settimeout(5.0)
    conn, _ = srv.accept()
    conn.settimeout(0.05)
    relay = Relay(lambda: conn.recv(4096), conn.sendall, udp_port)
    try:
        return exercise(link, ap)
    finally:
        link.close()
        relay.close()
        ap.stop()
        conn.close()
        srv.close()


def run_serial(ap_key):
    import pty
    import select
    import tty

    udp_port = free_port(socket.SOCK_DGRAM)
    master, slave = pty.openpty()
    tty.setraw(slave)
    dev = os.ttyname(slave)

    def read():
        r, _, _ = select.select([master], [], [], 0.05)
        return os.read(master, 4096) if r else b""

    ap = SimAutopilot("127.0.0.1", udp_port, 7, boot_unix_s=time.time() - 5.0, signing_key=ap_key).start()
    relay = Relay(read, lambda d: os.write(master, d), udp_port)
    link = AutopilotLink(f"{dev}:57600", target_system=7, signing_key=KEY).start()
    try:
        return exercise(link, ap)
    finally:
        link.close()
        relay.close()
        ap.stop()
        os.close(master)
        os.close(slave)


def main() -> int:
    assert "MAVLINK20" not in os.environ, "this probe must run without MAVLINK20"
    run = {"tcp": run_tcp, "serial": run_serial}[sys.argv[1]]
    print(json.dumps({"case": sys.argv[2], **run(CASES[sys.argv[2]])}), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
