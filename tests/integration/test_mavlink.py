"""The autopilot link against a simulated autopilot over real UDP on loopback."""

import os
import socket
import time

import pytest

from uvteam.autopilot import MissionItem, mavlink2
from uvteam.io.mavlink import AutopilotLink
from uvteam_sim.autopilot import SimAutopilot


def wait_for(cond, timeout=3.0):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if cond():
            return True
        time.sleep(0.01)
    return False


@pytest.fixture
def pair(udp_port):
    link = AutopilotLink(f"udpin:127.0.0.1:{udp_port}", target_system=7).start()
    ap = SimAutopilot("127.0.0.1", udp_port, 7, boot_unix_s=time.time() - 100.0).start()
    yield link, ap
    link.close()
    ap.stop()


def test_position_with_capture_time(pair):
    link, ap = pair
    assert wait_for(lambda: link.link_up)
    assert wait_for(lambda: link._boot_offset_s is not None)  # SYSTEM_TIME seen
    cap = time.time() - 0.25  # captured 250 ms ago (latency)
    ap.send_position(cap, 31.4851, -111.5441, 1301.0, 1.0, 123.4, 1.5, -0.5, 0.8)
    # position (GLOBAL_POSITION_INT) and its accuracy (GPS_RAW_INT) are two messages: wait for both
    assert wait_for(lambda: link.state() is not None and link.state().h_acc_m is not None)
    st = link.state()
    assert st.stamp_source == "autopilot" and abs(st.stamp_s - cap) < 0.005
    assert st.lat_deg == pytest.approx(31.4851, abs=1e-7) and st.lon_deg == pytest.approx(-111.5441, abs=1e-7)
    assert st.heading_deg == pytest.approx(123.4, abs=0.01) and st.h_acc_m == pytest.approx(0.8, abs=1e-3)
    assert st.v_east_m_s == pytest.approx(1.5) and st.v_north_m_s == pytest.approx(-0.5)


def test_mission_round_trip(pair):
    link, ap = pair
    assert wait_for(lambda: link.link_up)
    items = [MissionItem(mavlink2.MAV_CMD_DO_CHANGE_SPEED, param1=1, param2=2.5)] + [
        MissionItem(mavlink2.MAV_CMD_NAV_WAYPOINT, 31.485 + 1e-5 * k, -111.544 - 1e-5 * k, 0.0) for k in range(5)]
    link.upload_mission(items)
    assert len(ap.mission) == 6 and ap.mission[3].lat_deg == pytest.approx(31.48502, abs=1e-7)
    got = link.download_mission()
    assert [i.command for i in got] == [i.command for i in items]
    assert got[0].param2 == pytest.approx(2.5)
    assert all(abs(a.lat_deg - b.lat_deg) < 1e-7 and abs(a.lon_deg - b.lon_deg) < 1e-7 for a, b in zip(got, items))


def test_garbage_does_not_stop_fix_stream(pair):
    link, ap = pair
    assert wait_for(lambda: link.link_up)
    port = link._transport.sock.getsockname()[1]
    rnd = os.urandom
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as junk:
        seen = 0
        for k in range(50):
            junk.sendto(rnd(1 + k * 7 % 300), ("127.0.0.1", port))
            junk.sendto(b"\xfd\x09\x00\x00" + rnd(5), ("127.0.0.1", port))  # truncated MAVLink 2 header
            ap.send_position(time.time(), 31.485 + k * 1e-6, -111.544, 1300.0, 0.0, 10.0, 0.0, 0.0, 1.0)
            lat = 31.485 + k * 1e-6
            if wait_for(lambda: link.state() is not None and abs(link.state().lat_deg - lat) < 1e-8, 0.5):
                seen += 1
    assert seen == 50, f"only {seen}/50 fixes got through the garbage"
    assert link.link_up


def test_other_systems_are_ignored(udp_port):
    link = AutopilotLink(f"udpin:127.0.0.1:{udp_port}", target_system=7).start()
    other = SimAutopilot("127.0.0.1", udp_port, 8, boot_unix_s=time.time()).start()
    try:
        other.send_position(time.time(), 10.0, 10.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0)
        time.sleep(0.3)
        assert link.state() is None and not link.link_up
        assert link.counters["ignored_source"] > 0
    finally:
        link.close()
        other.stop()


def test_link_down_after_silence(pair):
    link, ap = pair
    link.link_timeout_s = 0.5
    assert wait_for(lambda: link.link_up)
    ap.go_silent()
    assert wait_for(lambda: not link.link_up, 2.0)
    assert link.link_state == "down"


# --- MAVLink 2 signing -----------------------------------------------------------------------------
KEY = bytes(range(32))


@pytest.mark.parametrize("ap_key, ok", [(KEY, True), (None, False), (bytes(32), False)],
                         ids=["same key", "autopilot unsigned", "wrong key"])
def test_signing_accepts_only_the_shared_key(udp_port, ap_key, ok):
    link = AutopilotLink(f"udpin:127.0.0.1:{udp_port}", target_system=7, signing_key=KEY).start()
    ap = SimAutopilot("127.0.0.1", udp_port, 7, boot_unix_s=time.time() - 10.0, signing_key=ap_key).start()
    try:
        for k in range(10):
            ap.send_position(time.time(), 31.485, -111.544, 1300.0, 0.0, 10.0, 0.0, 0.0, 1.0)
            time.sleep(0.03)
        assert wait_for(lambda: link.state() is not None, 1.0) is ok
        assert link.link_up is ok
        if ok:  # and the link's own messages are signed: the autopilot, requiring signatures, takes a mission
            link.upload_mission([MissionItem(mavlink2.MAV_CMD_NAV_WAYPOINT, 31.4851, -111.5441, 0.0)])
            assert len(ap.mission) == 1
    finally:
        link.close()
        ap.stop()


def test_unsigned_link_is_refused_by_a_signing_autopilot(udp_port):
    link = AutopilotLink(f"udpin:127.0.0.1:{udp_port}", target_system=7).start()
    ap = SimAutopilot("127.0.0.1", udp_port, 7, boot_unix_s=time.time(), signing_key=KEY).start()
    try:
        with pytest.raises(Exception):
            link.upload_mission([MissionItem(mavlink2.MAV_CMD_NAV_WAYPOINT, 31.4851, -111.5441, 0.0)],
                                timeout_s=0.2, retries=2)
        assert ap.mission == []
    finally:
        link.close()
        ap.stop()


# --- TCP and serial links (through pymavlink's mavutil) -------------------------------------------
class StreamRelay:
    """Joins a byte stream (TCP socket or pty) to a SimAutopilot's UDP side, one MAVLink message per
    datagram each way, as a router such as mavlink-router would."""

    def __init__(self, read, write, udp_port: int) -> None:
        import threading

        self.read, self.write = read, write
        self.udp = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.udp.bind(("127.0.0.1", udp_port))
        self.udp.settimeout(0.05)
        self.ap_addr = None
        self.stop = threading.Event()
        self.parser = mavlink2.MAVLink(None)
        self.threads = [threading.Thread(target=f, daemon=True) for f in (self._down, self._up)]
        for t in self.threads:
            t.start()

    def _down(self):  # autopilot -> stream
        while not self.stop.is_set():
            try:
                data, self.ap_addr = self.udp.recvfrom(4096)
            except (TimeoutError, OSError):
                continue
            try:
                self.write(data)
            except OSError:
                return

    def _up(self):  # stream -> autopilot
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


def _exercise(link, ap):
    assert wait_for(lambda: link.link_up, 5.0)
    ap.send_position(time.time(), 31.4852, -111.5442, 1300.0, 0.0, 45.0, 0.0, 0.0, 1.0)
    assert wait_for(lambda: link.state() is not None and abs(link.state().lat_deg - 31.4852) < 1e-7, 3.0)
    items = [MissionItem(mavlink2.MAV_CMD_NAV_WAYPOINT, 31.485 + 1e-5 * k, -111.544, 0.0) for k in range(4)]
    link.upload_mission(items)
    assert len(ap.mission) == 4
    assert [round(i.lat_deg, 7) for i in link.download_mission()] == [round(i.lat_deg, 7) for i in items]


def test_tcp_link(tcp_port, udp_port):
    srv = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    srv.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    srv.bind(("127.0.0.1", tcp_port))
    srv.listen(1)
    ap = SimAutopilot("127.0.0.1", udp_port, 7, boot_unix_s=time.time() - 5.0).start()
    link = AutopilotLink(f"tcp:127.0.0.1:{tcp_port}", target_system=7).start()
    srv.settimeout(5.0)
    conn, _ = srv.accept()
    conn.settimeout(0.05)
    relay = StreamRelay(lambda: conn.recv(4096), conn.sendall, udp_port)
    try:
        _exercise(link, ap)
    finally:
        link.close()
        relay.close()
        ap.stop()
        conn.close()
        srv.close()


def test_serial_link(udp_port):
    import pty
    import select
    import tty

    master, slave = pty.openpty()
    tty.setraw(slave)
    dev = os.ttyname(slave)

    def read():
        r, _, _ = select.select([master], [], [], 0.05)
        return os.read(master, 4096) if r else b""

    ap = SimAutopilot("127.0.0.1", udp_port, 7, boot_unix_s=time.time() - 5.0).start()
    relay = StreamRelay(read, lambda d: os.write(master, d), udp_port)
    link = AutopilotLink(f"{dev}:57600", target_system=7).start()
    try:
        _exercise(link, ap)
    finally:
        link.close()
        relay.close()
        ap.stop()
        os.close(master)
        os.close(slave)
