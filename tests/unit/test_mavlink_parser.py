"""MAVLink framing with resync and signature checks (no sockets)."""

import pytest

from uvteam.autopilot import mavlink2
from uvteam.io.mavlink import DatagramParser, MavlinkParser, signing_timestamp

KEY = bytes(range(32))


def packer(sysid=7, compid=1, key=None, link_id=0, stamp=None):
    """pack(msg) -> bytes, as the autopilot `sysid` would send it (signed with `key` if given)."""
    mav = mavlink2.MAVLink(None, sysid, compid)
    if key is not None:
        mav.signing.secret_key, mav.signing.sign_outgoing, mav.signing.link_id = key, True, link_id
        mav.signing.timestamp = signing_timestamp() if stamp is None else stamp

    def pack(msg):
        buf = msg.pack(mav)
        mav.seq = (mav.seq + 1) % 256
        return buf
    return pack


def pos(k):
    return mavlink2.MAVLink_global_position_int_message(k, 314850000 + k, -1115440000, 1300000, 0, 0, 0, 0, 100)


P = packer()
A, B = P(pos(1)), P(pos(2))
V1 = mavlink2.MAVLink_heartbeat_message(10, 3, 0, 0, 4, 3).pack(mavlink2.MAVLink(None, 7, 1), force_mavlink1=True)
NOISE = bytes([0x11, 0x22, 0x33, 0x00, 0x44])
BAD_CRC = A[:-1] + bytes([A[-1] ^ 0xFF])
FALSE_START = bytes([0xFD, 0xF0, 0x00])            # a v2 start byte announcing a 240-byte payload
UNKNOWN_FLAG = bytes([0xFD, 0x05, 0x80]) + bytes(9)


@pytest.mark.parametrize("datagram, want", [
    (A, [A]),                                     # a plain packet
    (NOISE + A, [A]),                             # noise before it (pymavlink: "invalid prefix", lost)
    (NOISE + A + NOISE + B + NOISE, [A, B]),      # noise before, between and after two packets
    (A[:20] + B, [B]),                            # a truncated packet before a good one
    (BAD_CRC + B, [B]),                           # a corrupted packet before a good one
    (FALSE_START + A + B, [A, B]),                # a false start byte whose "frame" spans both packets
    (UNKNOWN_FLAG + A, [A]),                      # an unknown incompatibility flag: not a frame
    (A + B[:-3], [A]),                            # a good packet, then a truncated one at the end
    (NOISE + V1 + A, [V1, A]),                    # MAVLink 1 and 2 in one datagram
    (b"", []),                                    # empty datagram
    (b"\xfd", []),                                # a lone start byte
    (bytes([0xFE, 0x09]), []),                    # a v1 header cut after two bytes
])
def test_datagram_keeps_every_valid_packet(datagram, want):
    p = DatagramParser()
    assert [bytes(m.get_msgbuf()) for m in p.parse(datagram)] == want
    # and nothing carries over into the next datagram
    assert [bytes(m.get_msgbuf()) for m in p.parse(B)] == [B]


@pytest.mark.parametrize("stream", [
    NOISE + A + NOISE + B,                        # noise around two packets
    FALSE_START + A + B + bytes(300),             # a false start byte: its packets come once 280 bytes followed
    BAD_CRC + A + B,                              # a corrupted packet first
    A[:15] + A + B,                               # a packet cut off by a reconnect, then the stream goes on
])
@pytest.mark.parametrize("chunk", [1, 7, 64, 4096])
def test_stream_keeps_every_valid_packet_whatever_the_chunking(stream, chunk):
    p = MavlinkParser(datagram=False)
    got = []
    for k in range(0, len(stream), chunk):
        got += p.parse(stream[k:k + chunk])
    assert [bytes(m.get_msgbuf()) for m in got] == [A, B]


def test_stream_waits_for_a_frame_split_across_chunks():
    p = MavlinkParser(datagram=False)
    assert p.parse(A[:10]) == []
    assert [bytes(m.get_msgbuf()) for m in p.parse(A[10:])] == [A]


# --- signing -------------------------------------------------------------------------------------------
def test_signing_lets_only_valid_signatures_through():
    p = DatagramParser(KEY)
    good = packer(key=KEY)
    cases = [
        (good(pos(1)), True),                                  # signed with the key
        (P(pos(2)), False),                                    # unsigned
        (packer(key=bytes(32))(pos(3)), False),                # signed with another key
        (V1, False),                                           # MAVLink 1 cannot be signed
        (packer(key=KEY, link_id=1, stamp=signing_timestamp() - 100 * 100_000)(pos(4)), False),  # new stream, 100 s old
    ]
    for buf, ok in cases:
        assert bool(p.parse(buf)) is ok
    assert p.counters["unsigned"] == 2 and p.counters["bad_signature"] == 1 and p.counters["stale_stream"] == 1


@pytest.mark.parametrize("key", [None, KEY], ids=["link unsigned", "link signing"])
def test_a_signed_packet_cut_after_its_crc_does_not_swallow_the_next(key):
    # the CRC does not cover the 13-byte signature block: a signed packet cut right after its CRC
    # decodes, with the next packet's first 13 bytes as its "signature"
    pack = packer(key=KEY)
    cut, good = pack(pos(1))[:-13], pack(pos(2))
    assert [bytes(m.get_msgbuf()) for m in DatagramParser(key).parse(cut + good)][-1:] == [good]


def test_signing_refuses_a_replay():
    p = DatagramParser(KEY)
    buf = packer(key=KEY)(pos(1))
    assert len(p.parse(buf)) == 1
    assert p.parse(buf) == [] and p.counters["replayed"] == 1


def test_a_forged_future_timestamp_does_not_lock_the_genuine_stream_out():
    # pymavlink records a stream's timestamp before checking the HMAC: one forged packet with a far
    # future timestamp made every genuine packet after it "old". The HMAC is checked first here.
    p = DatagramParser(KEY)
    forged = packer(key=bytes(32), stamp=signing_timestamp() + 10**12)(pos(1))
    assert p.parse(forged) == []
    genuine = packer(key=KEY)
    assert [len(p.parse(genuine(pos(k)))) for k in range(5)] == [1] * 5


def test_key_length_is_checked():
    with pytest.raises(ValueError, match="signing_key"):
        DatagramParser(bytes(16))
