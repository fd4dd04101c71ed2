"""Fuzzing the link's ingest (parser + handler) with Hypothesis: random bytes, truncated and corrupted
real packets, packets from other systems and forged ones, mixed into datagrams (UDP) or cut anywhere
(TCP/serial stream). Properties: no exception; no state, heartbeat or mission reply from a foreign system;
every valid packet of the target is used, once, in order; the UDP reply address is only ever the
autopilot's. Bounded for CI (a few seconds; UVTEAM_FUZZ_EXAMPLES=5000 for a longer hunt); no sockets.
"""

import os

from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from uvteam.autopilot import mavlink2
from uvteam.io.mavlink import AutopilotLink, signing_timestamp

TARGET = 7
KEY = bytes(range(32))
AP_ADDR, STRANGER_ADDR = ("192.0.2.7", 14550), ("198.51.100.66", 40000)
TARGET_LAT_E7 = 314850000


def target_msgs():
    return [
        mavlink2.MAVLink_heartbeat_message(10, mavlink2.MAV_AUTOPILOT_ARDUPILOTMEGA, 0, 0, 4, 3),
        mavlink2.MAVLink_system_time_message(1_790_000_000_000_000, 5000),
        mavlink2.MAVLink_gps_raw_int_message(5_000_000, 3, TARGET_LAT_E7, -1115440000, 1300000, 80, 120, 0, 0, 12,
                                             0, 800, 2000, 50, 0, 0),
        mavlink2.MAVLink_global_position_int_message(5000, TARGET_LAT_E7 + 3, -1115440000, 1300000, 0, 10, 10, 0, 9000),
        mavlink2.MAVLink_attitude_message(5000, 0.01, -0.02, 1.5, 0.0, 0.0, 0.0),
        mavlink2.MAVLink_mission_count_message(245, mavlink2.MAV_COMP_ID_ONBOARD_COMPUTER, 3, 0),
    ]


def foreign_msgs():
    return [
        mavlink2.MAVLink_heartbeat_message(2, mavlink2.MAV_AUTOPILOT_PX4, 0, 0, 4, 3),
        mavlink2.MAVLink_global_position_int_message(5000, 100000000, 100000000, 0, 0, 0, 0, 0, 0),   # 10 deg N 10 E
        mavlink2.MAVLink_gps_raw_int_message(5_000_000, 1, 100000000, 100000000, 0, 9999, 9999, 0, 0, 0,
                                             0, 1, 0, 0, 0, 0),
        mavlink2.MAVLink_mission_count_message(245, mavlink2.MAV_COMP_ID_ONBOARD_COMPUTER, 99, 0),
    ]


def packer(sysid, compid=1, key=None):
    mav = mavlink2.MAVLink(None, sysid, compid)
    if key is not None:
        mav.signing.secret_key, mav.signing.sign_outgoing = key, True
        mav.signing.timestamp = signing_timestamp()

    def pack(msg):
        buf = msg.pack(mav)
        mav.seq = (mav.seq + 1) % 256
        return buf
    return pack


noise = st.one_of(st.binary(max_size=40),
                  st.lists(st.sampled_from([0xFD, 0xFE, 0x00, 0x01, 0x09, 0x1C, 0xFF]), max_size=40).map(bytes))
segment = st.one_of(
    st.tuples(st.just("noise"), noise),
    st.tuples(st.just("target"), st.integers(0, 5)),
    st.tuples(st.just("foreign"), st.integers(0, 3), st.sampled_from([8, 1, 255])),
    st.tuples(st.just("truncated"), st.integers(0, 5), st.integers(1, 60)),
    st.tuples(st.just("corrupted"), st.integers(0, 5), st.integers(0, 80), st.integers(1, 255)),
    st.tuples(st.just("spoofed"), st.integers(0, 5)),      # the target's ids, unsigned or with another key
)
datagrams = st.lists(st.tuples(st.booleans(), st.lists(segment, max_size=8)), min_size=1, max_size=6)


def build(dgrams, signing: bool):
    """[(addr, bytes)] and the target packets that must come out, in order."""
    good = packer(TARGET, key=KEY if signing else None)
    spoof = packer(TARGET, key=bytes(32) if signing else None)
    out, want = [], []
    for from_ap, segs in dgrams:
        data = b""
        for seg in segs:
            kind = seg[0]
            if kind == "noise":
                data += seg[1]
            elif kind == "target" and from_ap:                 # a stranger cannot send valid target packets
                pkt = good(target_msgs()[seg[1]])
                data += pkt
                want.append(pkt)
            elif kind == "foreign" or kind == "target":
                data += packer(seg[2] if kind == "foreign" else 8)(foreign_msgs()[seg[1] % 4])
            elif kind == "truncated":   # cut, and the next byte is not the one that was cut off:
                pkt = good(target_msgs()[seg[1]])   # whatever follows must not complete it by chance
                k = min(seg[2], len(pkt) - 1)
                data += pkt[:k] + bytes([pkt[k] ^ 0xFF])
            elif kind == "corrupted":
                pkt = bytearray(good(target_msgs()[seg[1]]))
                pkt[seg[2] % len(pkt)] ^= seg[3]
                data += bytes(pkt)
            elif kind == "spoofed" and (signing or not from_ap):
                data += spoof(target_msgs()[seg[1]]) if signing else b""
        out.append((AP_ADDR if from_ap else STRANGER_ADDR, data))
    return out, want


def check_no_foreign_effect(link):
    st_ = link.state()
    assert st_ is None or abs(st_.lat_deg * 1e7 - TARGET_LAT_E7) < 10        # never the foreign 10 deg N
    assert link.autopilot in (None, mavlink2.MAV_AUTOPILOT_ARDUPILOTMEGA)   # never the foreign PX4 heartbeat
    while not link._mission_q.empty():
        m = link._mission_q.get_nowait()
        assert m.get_srcSystem() == TARGET and m.count == 3


FUZZ = settings(max_examples=int(os.environ.get("UVTEAM_FUZZ_EXAMPLES", "400")), deadline=None, suppress_health_check=[HealthCheck.too_slow])


@FUZZ
@given(dgrams=datagrams, signing=st.booleans())
def test_udp_ingest(dgrams, signing):
    link = AutopilotLink("udpin:127.0.0.1:9", target_system=TARGET, signing_key=KEY if signing else None)
    sent, want = build(dgrams, signing)
    got = []
    for addr, data in sent:
        used = link.ingest(data, addr)
        got += used
        assert link.reply_addr in (None, AP_ADDR)
        if used:
            assert link.reply_addr == AP_ADDR
    assert [bytes(m.get_msgbuf()) for m in got] == want
    check_no_foreign_effect(link)


@FUZZ
@given(dgrams=datagrams, signing=st.booleans(), cuts=st.lists(st.integers(1, 97), max_size=30))
# found by this test in CI (2026-12-05): 8 bytes of noise made an unsigned MAVLink 1 frame whose CRC matched,
# which swallowed the start of the signed packet behind it
@example(dgrams=[(False, [("truncated", 0, 1)] * 4),
                 (True, [("target", 0), ("noise", b"\xfe\x08\xa9b\xc2\xaf\xb2\xec"), ("target", 3)])],
         signing=True, cuts=[])
def test_stream_ingest(dgrams, signing, cuts):
    link = AutopilotLink("tcp:127.0.0.1:9", target_system=TARGET, signing_key=KEY if signing else None)
    sent, want = build(dgrams, signing)
    stream = b"".join(d for _, d in sent) + bytes(300)    # the stream goes on (autopilots stream steadily)
    got, i = [], 0
    for c in cuts + [len(stream)]:
        got += link.ingest(stream[i:i + c])
        i += c
    got += link.ingest(stream[i:])
    assert [bytes(m.get_msgbuf()) for m in got] == want
    check_no_foreign_effect(link)
