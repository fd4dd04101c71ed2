import math

import msgpack
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from uvteam import keys
from uvteam.bus import InMemoryBus, keyexpr_matches
from uvteam.errors import MessageError
from uvteam.messages import (Blob, Crowd, Crowds, Detections, Fix, Landmark, Plan, Status, Waypoint, decode,
                             encode)

FIX = Fix("ugv1", 1.7e9, 31.485, -111.544, 1300.0, 90.0, 0.8, 1.0, -0.5)


@settings(max_examples=200, deadline=None)
@given(st.floats(-90, 90), st.floats(-180, 180), st.floats(0, 359.99), st.floats(0, 100),
       st.floats(1.0, 4e9), st.text(alphabet="abc123_-", min_size=1, max_size=8))
def test_fix_round_trip(lat, lon, hdg, acc, stamp, vid):
    m = Fix(vid, stamp, lat, lon, 1300.0, hdg, acc)
    assert decode(Fix, encode(m)) == m


def test_nested_round_trip():
    d = Detections("uav1", 1.7e9, 3, 1280, 720, 50.0, (Landmark("ugv1", 10.5, 20.0),),
                   (Blob(100, 100, 90, 90, 110, 110), Blob(5, 6, 1, 2, 9, 10, 0.5, -0.5)))
    assert decode(Detections, encode(d)) == d
    p = Plan("ugv1", 1.7e9, (Waypoint(1.7e9 + 1, 31.0, -111.0), Waypoint(1.7e9 + 2, 31.0001, -111.0)))
    assert decode(Plan, encode(p)) == p
    c = Crowds("uav1", 1.7e9, "exact", ("ugv1",), (), (Crowd(1, 31.0, -111.0, (31.0,) * 4, (-111.0,) * 4, 1.0, 0.0, 0.5, "exact", 0),))
    assert decode(Crowds, encode(c)) == c


def wire(schema, data):
    return msgpack.packb({"schema": schema, "data": data})


GOOD = encode(FIX)
GOOD_DATA = msgpack.unpackb(GOOD)["data"]


@pytest.mark.parametrize(
    "raw, field",
    [
        (b"", "<payload>"),                                                 # empty
        (b"\xc1garbage", "<payload>"),                                      # not msgpack
        (msgpack.packb([1, 2, 3]), "<envelope>"),                           # no envelope
        (wire("plan/1", GOOD_DATA), "schema"),                              # another message's schema
        (wire("fix/2", GOOD_DATA), "schema"),                               # a future version
        (wire("fix/1", {**GOOD_DATA, "lat_deg": float("nan")}), "lat_deg"),  # NaN never reaches the map
        (wire("fix/1", {**GOOD_DATA, "lon_deg": math.inf}), "lon_deg"),     # infinity
        (wire("fix/1", {**GOOD_DATA, "lat_deg": 91.0}), "lat_deg"),         # out of range
        (wire("fix/1", {**GOOD_DATA, "heading_deg": 360.0}), "heading_deg"),  # heading wraps at 360
        (wire("fix/1", {**GOOD_DATA, "h_acc_m": -1.0}), "h_acc_m"),         # negative accuracy
        (wire("fix/1", {**GOOD_DATA, "stamp_s": 0.0}), "stamp_s"),          # no time
        (wire("fix/1", {**GOOD_DATA, "lat_deg": "31.4"}), "lat_deg"),       # a string for a number
        (wire("fix/1", {**GOOD_DATA, "lat_deg": True}), "lat_deg"),         # a bool for a number
        (wire("fix/1", {k: v for k, v in GOOD_DATA.items() if k != "lon_deg"}), "lon_deg"),  # missing
        (wire("fix/1", {**GOOD_DATA, "extra": 1}), "extra"),                # unknown field
    ],
)
def test_bad_payloads_name_the_field(raw, field):
    with pytest.raises(MessageError) as e:
        decode(Fix, raw)
    assert e.value.field == field


def test_optional_fields_may_be_absent():
    data = {k: v for k, v in GOOD_DATA.items() if k not in ("v_east_m_s", "v_north_m_s")}
    assert decode(Fix, wire("fix/1", data)).v_east_m_s == 0.0


def test_sender_refuses_nan():
    with pytest.raises(MessageError):
        encode(Fix("ugv1", 1.7e9, float("nan"), 0.0, 0.0, 0.0, 1.0))


def test_in_memory_bus_counts_and_drops_bad_messages():
    a = InMemoryBus()
    b = InMemoryBus(a)
    got = []
    b.subscribe(keys.all_vehicles("t", "fix"), Fix, lambda k, m: got.append((k, m)))
    a.publish(keys.key("t", "ugv1", "fix"), FIX)
    a.put_raw(keys.key("t", "ugv2", "fix"), b"\x00\x01")
    a.put_raw(keys.key("t", "ugv2", "fix"), wire("fix/1", {**GOOD_DATA, "lat_deg": float("nan")}))
    a.publish(keys.key("t", "ugv1", "status"), Status("ugv1", "ugv", 1.7e9, "up", 0, 0))
    assert [k for k, _ in got] == ["uvteam/t/ugv1/fix"]
    assert b.rejected == {"uvteam/t/ugv2/fix": 2}


@pytest.mark.parametrize(
    "expr, key, ok",
    [
        ("uvteam/t/*/fix", "uvteam/t/ugv1/fix", True),     # one chunk
        ("uvteam/t/*/fix", "uvteam/t/a/b/fix", False),     # '*' is exactly one chunk
        ("uvteam/**", "uvteam/t/ugv1/fix", True),          # any depth
        ("uvteam/t/**", "uvteam/t", True),                 # '**' matches zero chunks too
        ("uvteam/t/ugv1/fix", "uvteam/t/ugv2/fix", False),  # literal
    ],
)
def test_keyexpr_matches(expr, key, ok):
    assert keyexpr_matches(expr, key) is ok


@pytest.mark.parametrize("bad", ["", "a/b", "*", "x" * 33, "ugv 1", "ugv#1"])
def test_ids_cannot_inject_key_syntax(bad):
    from uvteam.errors import ConfigError

    with pytest.raises(ConfigError):
        keys.key("team", bad, "fix")


def test_keys_built_one_way():
    assert keys.key("demo", "ugv1", "fix") == "uvteam/demo/ugv1/fix"
    assert keys.alive("demo", "ugv1") == "uvteam/demo/ugv1/alive"
    assert keys.vehicle_of("uvteam/demo/ugv1/fix") == "ugv1" and keys.topic_of("uvteam/demo/ugv1/fix") == "fix"
    with pytest.raises(ValueError):
        keys.key("demo", "ugv1", "nonsense")
