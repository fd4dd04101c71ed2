"""The autopilot link against strangers, noise, keys, real autopilots' mission rules and commands.

Every test here talks over real sockets on loopback (or a pty) to a SimAutopilot or a raw pymavlink peer.
"""

import json
import os
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from uvteam.autopilot import MissionItem, fix_from_state, mavlink2
from uvteam.errors import LinkError
from uvteam.io.mavlink import AutopilotLink
from uvteam_sim.autopilot import SimAutopilot

KEY = bytes(range(32))
HERE = Path(__file__).resolve().parent


def wait_for(cond, timeout=3.0):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if cond():
            return True
        time.sleep(0.01)
    return False


def packer(sysid, compid=1, key=None):
    mav = mavlink2.MAVLink(None, sysid, compid)
    if key is not None:
        mav.signing.secret_key, mav.signing.sign_outgoing = key, True
        mav.signing.timestamp = int((time.time() - 1420070400) * 1e5)

    def pack(msg):
        buf = msg.pack(mav)
        mav.seq = (mav.seq + 1) % 256
        return buf
    return pack


def heartbeat():
    return mavlink2.MAVLink_heartbeat_message(mavlink2.MAV_TYPE_GROUND_ROVER, mavlink2.MAV_AUTOPILOT_ARDUPILOTMEGA,
                                              0, 0, mavlink2.MAV_STATE_ACTIVE, 3)


def position(k):
    return mavlink2.MAVLink_global_position_int_message(1000 + k, 314850000 + k, -1115440000, 1300000, 0, 0, 0, 0, 100)


@pytest.fixture
def udp_pair(udp_port, request):
    """A udpin link and the autopilot streaming to it; request.param = signing key (or None)."""
    key = getattr(request, "param", None)
    link = AutopilotLink(f"udpin:127.0.0.1:{udp_port}", target_system=7, signing_key=key).start()
    ap = SimAutopilot("127.0.0.1", udp_port, 7, boot_unix_s=time.time() - 100.0, signing_key=key).start()
    yield link, ap
    link.close()
    ap.stop()


# --- finding 1: a stranger's datagram never changes where replies go ---------------------------------------
STRANGERS = [
    # (what the stranger sends, the link's and the autopilot's signing key)
    (lambda: b"\x00", None),                                            # one byte
    (lambda: packer(99)(heartbeat()), None),                            # a valid packet of another system
    (lambda: packer(7, key=bytes(32))(heartbeat()), KEY),               # the target's id, wrong key
    (lambda: packer(7)(heartbeat()), KEY),                              # the target's id, unsigned
]


@pytest.mark.parametrize("udp_pair, payload", [(k, p) for p, k in STRANGERS], indirect=["udp_pair"],
                         ids=["one byte", "other system", "forged signature", "unsigned spoof"])
def test_stranger_datagrams_never_redirect_replies(udp_pair, payload):
    link, ap = udp_pair
    assert wait_for(lambda: link.link_up)
    port = link._transport.sock.getsockname()[1]
    stop = threading.Event()
    heard = []
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as stranger:
        stranger.bind(("127.0.0.1", 0))
        stranger.settimeout(0.005)

        def flood():  # a datagram every 5 ms: more often than anything the autopilot sends
            while not stop.is_set():
                stranger.sendto(payload(), ("127.0.0.1", port))
                try:
                    heard.append(stranger.recv(65535))
                except OSError:
                    pass
        t = threading.Thread(target=flood, daemon=True)
        t.start()
        try:
            time.sleep(1.2)  # long enough for the link's 1 Hz heartbeat
            link.upload_mission([MissionItem(mavlink2.MAV_CMD_NAV_WAYPOINT, 31.4851, -111.5441, 0.0)],
                                timeout_s=0.2, retries=3)
        finally:
            stop.set()
            t.join(timeout=2.0)
    assert len(ap.mission) == 1
    assert heard == [], f"the stranger received {len(heard)} datagrams meant for the autopilot"
    assert link.reply_addr == ap.sock.getsockname()


# --- finding 2: noise before or between packets loses nothing ---------------------------------------------
NOISE = bytes([0x11, 0x22, 0x33, 0x00, 0x44])


@pytest.mark.parametrize("layout", [
    lambda a, b: NOISE + a,                              # noise before a packet
    lambda a, b: NOISE + a + NOISE + b,                  # noise before and between two packets
    lambda a, b: a[:20] + b,                             # a truncated packet before a good one
    lambda a, b: a[:-1] + bytes([a[-1] ^ 0xFF]) + b,     # a corrupted packet (bad CRC) before a good one
    lambda a, b: bytes([0xFD, 0xF0, 0x00]) + a + b,      # a false start byte spanning both packets
    lambda a, b: a + b + NOISE,                          # noise after two packets
], ids=["before", "between", "truncated first", "corrupted first", "false start", "after"])
def test_noise_in_a_datagram_loses_no_packet(udp_port, layout):
    link = AutopilotLink(f"udpin:127.0.0.1:{udp_port}", target_system=7).start()
    pack = packer(7)
    sent = 0
    try:
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as ap:
            for k in range(10):
                packets = [pack(position(2 * k)), pack(position(2 * k + 1))]
                data = layout(*packets)
                sent += sum(p in data for p in packets)
                ap.sendto(data, ("127.0.0.1", udp_port))
                time.sleep(0.01)
            assert wait_for(lambda: link.counters["received"] >= sent, 2.0)
            time.sleep(0.1)
        assert link.counters["received"] == sent
        assert abs(link.state().lat_deg - (314850000 + 19) * 1e-7) < 1e-9 or sent < 20
    finally:
        link.close()


# --- finding 3: signing enforced on TCP and serial, in a process without MAVLINK20 -------------------------
@pytest.mark.parametrize("case, trusted", [
    ("same key", True),              # fixes, heartbeats and a mission upload go through
    ("autopilot unsigned", False),   # nothing from it is used
    ("wrong key", False),            # nothing from it is used
])
@pytest.mark.parametrize("transport", ["tcp", "serial"])
def test_signing_is_enforced_on_streams_without_mavlink20(transport, case, trusted):
    env = {k: v for k, v in os.environ.items() if not k.startswith("MAVLINK")}
    out = subprocess.run([sys.executable, str(HERE / "mavlink_signing_probe.py"), transport, case], env=env,
                         capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr[-2000:]
    got = json.loads(out.stdout.splitlines()[-1])
    assert got == {"case": case, "state": trusted, "link_up": trusted, "uploaded": trusted}


def test_tcp_link_reopens_after_the_autopilot_closes(tcp_port):
    """The autopilot (or its router) drops the TCP connection: the link reconnects and goes on."""
    hb = packer(7)
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as srv:
        srv.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        srv.bind(("127.0.0.1", tcp_port))
        srv.listen(1)
        srv.settimeout(5.0)
        link = AutopilotLink(f"tcp:127.0.0.1:{tcp_port}", target_system=7).start()
        try:
            conn, _ = srv.accept()
            conn.sendall(hb(heartbeat()))
            assert wait_for(lambda: link.link_up)
            conn.close()                                   # EOF on the link's side
            cpu0 = time.process_time()
            time.sleep(1.0)
            assert time.process_time() - cpu0 < 0.25       # no busy loop on EOF (mavutil's took ~90% of a core)
            conn, _ = srv.accept()                         # it comes back
            with conn:
                conn.sendall(hb(position(1)))
                assert wait_for(lambda: link.state() is not None)
            assert link.counters["reconnects"] >= 1
        finally:
            link.close()


# --- finding 4: the fix type and the accuracy come through as reported ------------------------------------
@pytest.mark.parametrize("fix_type, h_acc_mm, h_acc_m, usable", [
    (1, 1_000_000, 1000.0, False),    # no fix, 1 km (was: h_acc None -> a cautious 5 m on the bus)
    (0, 0, None, False),              # no GPS, accuracy not sent
    (2, 800, 0.8, False),             # 2D fix
    (3, 1_000_000, 1000.0, False),    # 3D fix but 1 km
    (3, 800, 0.8, True),              # 3D fix, 0.8 m
    (6, 20, 0.02, True),              # RTK fixed
])
def test_fix_type_and_accuracy_reach_the_state(udp_pair, fix_type, h_acc_mm, h_acc_m, usable):
    link, ap = udp_pair
    assert wait_for(lambda: link.link_up)
    tb = ap.boot_ms(time.time())
    ap._send(mavlink2.MAVLink_gps_raw_int_message(tb * 1000, fix_type, 314850000, -1115440000, 1300000, 9999, 9999,
                                                  0, 0, 0, 0, h_acc_mm, 0, 0, 0, 0))
    ap._send(position(1))
    assert wait_for(lambda: link.state() is not None and link.state().fix_type == fix_type, 2.0)
    st = link.state()
    assert st.h_acc_m == h_acc_m
    assert st.usable_fix(5.0) is usable
    if h_acc_m is not None:  # the bus message carries the reported accuracy, not a default
        assert fix_from_state("ugv1", st).h_acc_m == pytest.approx(h_acc_m)


# --- finding 5: missions as PX4 and ArduPilot want them ------------------------------------------------------
def station_items():
    import numpy as np

    from uvteam.geo import LocalFrame
    from uvteam.mission import plan_to_mission
    from uvteam.planning import plan_stations

    frame = LocalFrame(31.485, -111.544)
    plans = plan_stations([0, 0], [2.0, 0.0], {"a": np.array([-12.0, 0.0])}, 1000.0, radius_m=12.0)
    return frame, plan_to_mission(plans["a"], frame)


@pytest.mark.parametrize("autopilot, first_current_seq", [
    (mavlink2.MAV_AUTOPILOT_PX4, 0),            # PX4 starts at the item marked current: our first
    (mavlink2.MAV_AUTOPILOT_ARDUPILOTMEGA, 1),  # ArduPilot keeps HOME at 0 and starts at 1
], ids=["px4", "ardupilot"])
def test_station_mission_is_accepted_and_reads_back_the_same_plan(udp_port, autopilot, first_current_seq):
    from uvteam.mission import mission_to_plan

    frame, items = station_items()
    link = AutopilotLink(f"udpin:127.0.0.1:{udp_port}", target_system=7).start()
    ap = SimAutopilot("127.0.0.1", udp_port, 7, boot_unix_s=time.time() - 100.0, autopilot=autopilot).start()
    try:
        assert wait_for(lambda: link.mission_convention is not None)
        link.upload_mission(items)
        assert ap.rejected == [] and ap.current_seq == first_current_seq
        assert [(i.command, i.frame, i.param2) for i in ap.mission] == [(i.command, i.frame, i.param2) for i in items]
        got = link.download_mission()
        assert [i.current for i in got] == [1] + [0] * (len(items) - 1)   # the vehicle says: starts at our first
        assert [(i.command, i.frame) for i in got] == [(i.command, i.frame) for i in items]
        want = mission_to_plan("a", items, frame, [-12.0, 0.0], 1000.0, 4.0).waypoints
        back = mission_to_plan("a", got, frame, [-12.0, 0.0], 1000.0, 4.0).waypoints
        assert len(back) == len(want)
        for w, b in zip(want, back):  # the same plan, to the wire's 1e-7 deg (1 cm)
            assert b.lat_deg == pytest.approx(w.lat_deg, abs=1e-7) and b.lon_deg == pytest.approx(w.lon_deg, abs=1e-7)
            assert b.stamp_s == pytest.approx(w.stamp_s, abs=0.02)
    finally:
        link.close()
        ap.stop()


def test_px4_refuses_a_speed_item_in_a_global_frame(udp_port):
    # what the link sent before: DO_CHANGE_SPEED in MAV_FRAME_GLOBAL_RELATIVE_ALT_INT (PX4: UNSUPPORTED)
    link = AutopilotLink(f"udpin:127.0.0.1:{udp_port}", target_system=7).start()
    ap = SimAutopilot("127.0.0.1", udp_port, 7, boot_unix_s=time.time(), autopilot=mavlink2.MAV_AUTOPILOT_PX4).start()
    try:
        assert wait_for(lambda: link.mission_convention is not None)
        old = [MissionItem(mavlink2.MAV_CMD_DO_CHANGE_SPEED, param1=1, param2=2.0, param3=-1,
                           frame=mavlink2.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT),
               MissionItem(mavlink2.MAV_CMD_NAV_WAYPOINT, 31.4851, -111.5441, 0.0)]
        with pytest.raises(LinkError, match=f"MAV_MISSION_RESULT {mavlink2.MAV_MISSION_UNSUPPORTED}"):
            link.upload_mission(old)
        assert ap.rejected == [(0, mavlink2.MAV_MISSION_UNSUPPORTED)] and ap.mission == []
    finally:
        link.close()
        ap.stop()


# --- finding 6: COMMAND_LONG is answered ---------------------------------------------------------------------
def test_sim_autopilot_answers_command_long_raw(udp_port):
    """A raw pymavlink companion: COMMAND_LONG in, COMMAND_ACK out."""
    mav = mavlink2.MAVLink(None, 245, mavlink2.MAV_COMP_ID_ONBOARD_COMPUTER)
    acks = []
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as gcs:
        gcs.bind(("127.0.0.1", udp_port))
        gcs.settimeout(3.0)
        ap = SimAutopilot("127.0.0.1", udp_port, 7, boot_unix_s=time.time()).start()
        try:
            _, ap_addr = gcs.recvfrom(4096)          # its first heartbeat tells where it is
            gcs.settimeout(0.1)
            rows = [(mavlink2.MAV_CMD_DO_CHANGE_SPEED, [1, 2.5, -1, 0, 0, 0, 0]),
                    (mavlink2.MAV_CMD_REQUEST_MESSAGE, [mavlink2.MAVLINK_MSG_ID_HEARTBEAT, 0, 0, 0, 0, 0, 0]),
                    (mavlink2.MAV_CMD_NAV_TAKEOFF, [0] * 7)]
            for cmd, p in rows:
                gcs.sendto(mavlink2.MAVLink_command_long_message(7, 1, cmd, 0, *p).pack(mav), ap_addr)
            end = time.monotonic() + 2.0
            while len(acks) < 3 and time.monotonic() < end:
                try:
                    data = gcs.recv(4096)
                except OSError:
                    continue
                acks += [(m.command, m.result) for m in mav.parse_buffer(data) or [] if m.get_type() == "COMMAND_ACK"]
        finally:
            ap.stop()
    assert acks == [(mavlink2.MAV_CMD_DO_CHANGE_SPEED, mavlink2.MAV_RESULT_ACCEPTED),
                    (mavlink2.MAV_CMD_REQUEST_MESSAGE, mavlink2.MAV_RESULT_ACCEPTED),
                    (mavlink2.MAV_CMD_NAV_TAKEOFF, mavlink2.MAV_RESULT_UNSUPPORTED)]


@pytest.mark.parametrize("udp_pair", [None, KEY], indirect=True, ids=["unsigned", "signed"])
def test_link_command_long_gets_the_ack(udp_pair):
    link, ap = udp_pair
    assert wait_for(lambda: link.link_up)
    ok, unsupported, failed = mavlink2.MAV_RESULT_ACCEPTED, mavlink2.MAV_RESULT_UNSUPPORTED, mavlink2.MAV_RESULT_FAILED
    assert link.command_long(mavlink2.MAV_CMD_DO_CHANGE_SPEED, 1, 2.5, -1) == ok and ap.speed_m_s == 2.5
    gpi = mavlink2.MAVLINK_MSG_ID_GLOBAL_POSITION_INT
    assert link.command_long(mavlink2.MAV_CMD_REQUEST_MESSAGE, gpi) == failed      # nothing to send yet
    ap.send_position(time.time(), 31.4852, -111.5442, 1300.0, 0.0, 45.0, 0.0, 0.0, 1.0)
    assert wait_for(lambda: link.state() is not None)
    before = link.counters["received"]
    assert link.command_long(mavlink2.MAV_CMD_REQUEST_MESSAGE, gpi) == ok
    assert wait_for(lambda: link.counters["received"] > before)                    # and the message came
    assert link.command_long(mavlink2.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 10) == unsupported


# --- a stop is heard while the link waits for an autopilot gone quiet -------------------------------------
@pytest.mark.parametrize("exchange", ["upload", "download", "command"])
def test_a_wait_for_a_quiet_autopilot_gives_up_when_the_service_stops(udp_port, exchange):
    """An autopilot that heartbeats but answers nothing keeps an exchange retrying for seconds (0.5 s x 5
    by default); the service's stop flag ends it within a wait slice, so its thread joins on stop
    instead of outliving the bus (a thread inside zenoh at interpreter exit aborts the process)."""
    stop = threading.Event()
    link = AutopilotLink(f"udpin:127.0.0.1:{udp_port}", target_system=7, cancel=stop).start()
    pack = packer(7)
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as ap:
        try:
            ap.sendto(pack(heartbeat()), ("127.0.0.1", udp_port))
            assert wait_for(lambda: link.link_up)
            item = MissionItem(mavlink2.MAV_CMD_NAV_WAYPOINT, 31.48, -111.54, 0.0)
            call = {"upload": lambda: link.upload_mission([item]),
                    "download": link.download_mission,
                    "command": lambda: link.command_long(mavlink2.MAV_CMD_DO_CHANGE_SPEED, 1, 2.0, -1)}[exchange]
            threading.Timer(0.3, stop.set).start()
            t0 = time.monotonic()
            with pytest.raises(LinkError, match="stopped"):
                call()
            assert time.monotonic() - t0 < 0.3 + 0.3
        finally:
            link.close()
