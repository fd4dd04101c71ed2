"""The autopilot link against a simulated autopilot over real UDP on loopback."""

import os
import socket
import time

import pytest

from uvteam.autopilot import AutopilotLink, MissionItem, mavlink2
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
    assert wait_for(lambda: link.state() is not None)
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
