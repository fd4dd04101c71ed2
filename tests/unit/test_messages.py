import math
from dataclasses import replace

import msgpack
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import numpy as np

from uvteam import keys
from uvteam.blobs import Blobs, Landmarks
from uvteam.bus import InMemoryBus, keyexpr_matches
from uvteam.errors import MessageError
from uvteam.messages import (Crowd, Crowds, Detections, Fix, Frame, Plan, Status, Waypoint, decode, encode)

FIX = Fix("ugv1", 1.7e9, 31.485, -111.544, 1300.0, 90.0, 0.8, 1.0, -0.5, 3)


@settings(max_examples=200, deadline=None)
@given(st.floats(-90, 90), st.floats(-180, 180), st.floats(0, 359.99), st.floats(0, 100),
       st.floats(1.0, 4e9), st.text(alphabet="abc123_-", min_size=1, max_size=8))
def test_fix_round_trip(lat, lon, hdg, acc, stamp, vid):
    m = Fix(vid, stamp, lat, lon, 1300.0, hdg, acc)
    assert decode(Fix, encode(m)) == m


def detections(**kw):
    base = dict(vehicle="uav1", stamp_s=1.7e9, frame_seq=3, width_px=1280, height_px=720, alt_agl_m=50.0, focal_px=790.0,
                landmarks=Landmarks(("ugv1",), np.array([[10.5, 20.0]])),
                blobs=Blobs(np.array([[100.0, 100], [5, 6]]), np.array([[90.0, 90, 110, 110], [1, 2, 9, 10]]),
                            np.array([40.0, 12.0]), ("ugv1", "")),
                sigma_color_px=0.5, sigma_ugv_blob_px=4.0, sigma_crowd_blob_px=6.3)
    return Detections(**{**base, **kw})


def test_nested_round_trip():
    d = detections()
    back = decode(Detections, encode(d))
    assert back == d and back.blobs.xy_px.shape == (2, 2) and back.blobs.ugv == ("ugv1", "")
    assert back.sigma_crowd_blob_frame_px is None                 # unsaid: all of the crowd noise is per frame
    for part in (0.0, 2.5, 6.3):
        assert decode(Detections, encode(detections(sigma_crowd_blob_frame_px=part))).sigma_crowd_blob_frame_px == part
    moving = detections(blobs=Blobs(d.blobs.xy_px, d.blobs.xyxy_px, d.blobs.area_px, d.blobs.ugv,
                                    np.array([[0.0, 0.0], [12.5, -3.0]]), np.array([0.0, 0.8])))
    back = decode(Detections, encode(moving))
    assert back == moving and back != d and back.blobs.velocity_of(0) is None and back.blobs.velocity_of(1)[1] == 0.8
    empty = detections(landmarks=Landmarks(), blobs=Blobs.empty())
    assert decode(Detections, encode(empty)) == empty
    p = Plan("ugv1", 1.7e9, (Waypoint(1.7e9 + 1, 31.0, -111.0), Waypoint(1.7e9 + 2, 31.0001, -111.0)))
    assert decode(Plan, encode(p)) == p
    c = Crowds("loc1", "uav1", 1.7e9, "exact", ("ugv1",), (),
               (Crowd(1, 31.0, -111.0, (31.0,) * 4, (-111.0,) * 4, 1.0, 0.0, 0.5, "exact", 0),))
    assert decode(Crowds, encode(c)) == c
    coasted = Crowds("loc1", "uav1", 1.7e9, "exact", (), (), (replace(c.crowds[0], unseen_s=2.5),))
    assert decode(Crowds, encode(coasted)).crowds[0].unseen_s == 2.5
    st = Status("ugv1", "ugv", 1.7e9, "up", 0, 3, 4, {"crowds_latency_p99_ms": 3.5}, "fine")
    assert decode(Status, encode(st)) == st


def test_unknown_stays_unknown():
    # a fix without a heading, velocity or fix type says so: None on the wire, never 0
    f = Fix("ugv1", 1.7e9, 31.0, -111.0, 1300.0, None, 2.0)
    back = decode(Fix, encode(f))
    assert back.heading_deg is None and back.v_east_m_s is None and back.fix_type is None


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
        (wire("fix/3", GOOD_DATA), "schema"),                               # a future version
        (wire("fix/1", GOOD_DATA), "schema"),                               # an old version
        (wire("fix/2", {**GOOD_DATA, "lat_deg": float("nan")}), "lat_deg"),  # NaN never reaches the map
        (wire("fix/2", {**GOOD_DATA, "lon_deg": math.inf}), "lon_deg"),     # infinity
        (wire("fix/2", {**GOOD_DATA, "lat_deg": 91.0}), "lat_deg"),         # out of range
        (wire("fix/2", {**GOOD_DATA, "heading_deg": 360.0}), "heading_deg"),  # heading wraps at 360
        (wire("fix/2", {**GOOD_DATA, "h_acc_m": -1.0}), "h_acc_m"),         # negative accuracy
        (wire("fix/2", {**GOOD_DATA, "stamp_s": 0.0}), "stamp_s"),          # no time
        (wire("fix/2", {**GOOD_DATA, "stamp_s": 1e18}), "stamp_s"),         # a time no clock gives
        (wire("fix/2", {**GOOD_DATA, "lat_deg": "31.4"}), "lat_deg"),       # a string for a number
        (wire("fix/2", {**GOOD_DATA, "lat_deg": True}), "lat_deg"),         # a bool for a number
        (wire("fix/2", {k: v for k, v in GOOD_DATA.items() if k != "lon_deg"}), "lon_deg"),  # missing
        (wire("fix/2", {**GOOD_DATA, "extra": 1}), "extra"),                # unknown field
        (wire("fix/2", {**GOOD_DATA, "vehicle": ""}), "vehicle"),           # an empty id
        (wire("fix/2", {**GOOD_DATA, "vehicle": "**"}), "vehicle"),         # key-expression syntax as an id
        (wire("fix/2", {**GOOD_DATA, "vehicle": "../x"}), "vehicle"),       # a path as an id
        (wire("fix/2", {**GOOD_DATA, "fix_type": -1}), "fix_type"),         # a negative count
        (wire("fix/2", {**GOOD_DATA, "fix_type": 9}), "fix_type"),          # no such GPS fix type
        (wire("fix/2", {**GOOD_DATA, "v_east_m_s": None}), "v_north_m_s"),  # half a velocity
        (msgpack.packb({"schema": "fix/2", "data": GOOD_DATA, "x": 1}), "<envelope>"),  # more than the envelope
        (b"\x82" + b"\x91" * 300_000, "<payload>"),                        # a nesting bomb: refused by size
    ],
)
def test_bad_payloads_name_the_field(raw, field):
    with pytest.raises(MessageError) as e:
        decode(Fix, raw)
    assert e.value.field == field


def test_optional_fields_may_be_absent():
    data = {k: v for k, v in GOOD_DATA.items() if k not in ("v_east_m_s", "v_north_m_s")}
    assert decode(Fix, wire("fix/2", data)).v_east_m_s is None


def test_sender_refuses_nan():
    with pytest.raises(MessageError):
        encode(Fix("ugv1", 1.7e9, float("nan"), 0.0, 0.0, 0.0, 1.0))


DET = msgpack.unpackb(encode(detections()))["data"]


@pytest.mark.parametrize(
    "data, field",
    [
        ({**DET, "blobs": {**DET["blobs"], "xyxy_px": [[90, 90, 80, 110], [1, 2, 9, 10]]}}, "xyxy_px"),  # inverted box
        ({**DET, "blobs": {**DET["blobs"], "area_px": [-1.0, 3.0]}}, "area_px"),       # a negative area
        ({**DET, "blobs": {**DET["blobs"], "area_px": [1.0]}}, "blobs"),              # lists of different lengths
        ({**DET, "blobs": {**DET["blobs"], "xy_px": [[1, 2, 3], [4, 5, 6]]}}, "xy_px"),  # rows of the wrong width
        ({**DET, "blobs": {**DET["blobs"], "xy_px": [[1, 2], [4]]}}, "xy_px"),        # ragged rows
        ({**DET, "blobs": {**DET["blobs"], "xy_px": [["a", "b"], [4, 5]]}}, "xy_px"),  # strings for numbers
        ({**DET, "blobs": {**DET["blobs"], "ugv": ["*", ""]}}, "blobs"),               # a label that is no id
        ({**DET, "landmarks": {"ugv": ["ugv1", "ugv1"], "xy_px": [[1, 2], [3, 4]]}}, "ugv"),  # one UGV twice
        ({**DET, "focal_px": 0.0}, "focal_px"),                                        # no camera
        ({**DET, "sigma_crowd_blob_px": -1.0}, "sigma_crowd_blob_px"),                 # negative noise
        ({**DET, "frame_seq": -3}, "frame_seq"),                                       # a negative count
        ({**DET, "sigma_crowd_blob_frame_px": 7.0}, "sigma_crowd_blob_frame_px"),      # more per frame than in all
        ({**DET, "sigma_crowd_blob_frame_px": -0.5}, "sigma_crowd_blob_frame_px"),     # negative noise
        ({**DET, "sigma_crowd_blob_frame_px": float("nan")}, "sigma_crowd_blob_frame_px"),  # no number
        ({**DET, "blobs": {**DET["blobs"], "v_px_s": [[1.0, 2.0]], "sigma_v_px_s": [0.5]}}, "v_px_s"),  # 1 of 2 blobs
        ({**DET, "blobs": {**DET["blobs"], "v_px_s": [[1.0, 2.0], [0, 0]], "sigma_v_px_s": [0.5]}}, "v_px_s"),
        ({**DET, "blobs": {**DET["blobs"], "v_px_s": [[1.0, 2.0], [0, 0]], "sigma_v_px_s": [0.5, -1]}}, "sigma_v_px_s"),
        ({**DET, "blobs": {**DET["blobs"], "v_px_s": [[1.0, float("inf")], [0, 0]], "sigma_v_px_s": [0.5, 0]}},
         "v_px_s"),
    ],
)
def test_detections_rules(data, field):
    with pytest.raises(MessageError) as e:
        decode(Detections, wire("detections/4", data))
    assert e.value.field == field, e.value


@pytest.mark.parametrize(
    "msg, field",
    [
        (Crowd(1, 31.0, -111.0, (31.0,) * 4, (-111.0,) * 3, 1.0, 0.0, 0.5, "exact", 0), "footprint_lon_deg"),  # 4 lat, 3 lon
        (Crowd(1, 31.0, -111.0, (), (), 1.0, 0.0, 0.5, "great", 0), "quality"),                    # no such quality
        (Crowd(1, 31.0, -111.0, (), (), 1.0, 0.0, 0.5, "exact", 0, -0.1), "unseen_s"),             # unseen < 0 s
        (Frame("uav1", 1.7e9, 1, 4, 2, "bgr8", b"\x00" * 23), "data"),                             # 4x2x3 needs 24 bytes
        (Frame("uav1", 1.7e9, 1, 4, 2, "png", b"\x00"), "encoding"),                               # unknown encoding
        (Status("ugv1", "boat", 1.7e9, "up", 0, 0), "service"),                                   # unknown service
    ],
)
def test_schema_rules_at_the_sender(msg, field):
    with pytest.raises(MessageError) as e:
        encode(msg)
    assert e.value.field == field, e.value


def test_a_bomb_costs_little_to_refuse():
    import time
    import tracemalloc

    # as big a detections payload as is let in, made of the cheapest objects to send and dearest to
    # unpack: small nested arrays and maps. Each is refused within 50 MB and 50 ms of this process's CPU
    # (without tracing; CPU time, so that other work on a loaded machine does not count)
    for filler in ([], [0], {}):
        n = Detections.MAX_BYTES // (len(msgpack.packb(filler)) * 9_000)
        bomb = msgpack.packb({"schema": "detections/4", "data": {"blobs": [[filler] * 9_000] * n}})
        assert len(bomb) <= Detections.MAX_BYTES
        took = []
        for _ in range(3):    # the least of three: a collection of what earlier tests left is not the bomb's
            t0 = time.process_time()
            with pytest.raises(MessageError):
                decode(Detections, bomb)
            took.append(time.process_time() - t0)
        took = min(took)
        tracemalloc.start()
        with pytest.raises(MessageError):
            decode(Detections, bomb)
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        assert peak < 50e6 and took < 0.05, (filler, peak, took)


def test_in_memory_bus_counts_and_drops_bad_messages():
    a = InMemoryBus()
    b = InMemoryBus(a)
    got = []
    b.subscribe(keys.all_vehicles("t", "fix"), Fix, lambda k, m: got.append((k, m)))
    a.publish(keys.key("t", "ugv1", "fix"), FIX)
    a.put_raw(keys.key("t", "ugv2", "fix"), b"\x00\x01")
    a.put_raw(keys.key("t", "ugv2", "fix"), wire("fix/2", {**GOOD_DATA, "lat_deg": float("nan")}))
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
