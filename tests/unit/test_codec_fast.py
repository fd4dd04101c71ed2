"""The fast decoder (msgspec structs generated from the messages) against the checked one: on valid
messages and on payloads mutated field by field, whatever the fast one accepts the checked one accepts
as the same message; everything else goes to the checked one, so every refusal names the same field."""

import math

import msgpack
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from uvteam import messages as M
from uvteam.blobs import Blobs, Landmarks
from uvteam.errors import MessageError
from uvteam.messages import Crowd, Crowds, Detections, Fix, Plan, Status, Waypoint, decode, encode

DET = Detections("uav1", 1.7e9, 3, 1280, 720, 50.0, 790.0, Landmarks(("ugv1", "ugv2"), np.array([[10.5, 20.0], [3, 4]])),
                 Blobs(np.array([[100.0, 100], [5, 6]]), np.array([[90.0, 90, 110, 110], [1, 2, 9, 10]]),
                       np.array([40.0, 12.0]), ("ugv1", "")), 0.5, 4.0, 6.3)
VALID = [
    Fix("ugv1", 1.7e9, 31.485, -111.544, 1300.0, 90.0, 0.8, 1.0, -0.5, 3),     # every field set
    Fix("ugv1", 1.7e9, -90.0, 180.0, 0.0, None, 0.0),                           # bounds, unknowns
    DET,
    Detections("uav1", 1.7e9, 0, 1, 1, 0.0, 1e-3, Landmarks(), Blobs.empty(), 0.0, 0.0, 0.0),   # nothing seen
    Plan("ugv1", 1.7e9, (Waypoint(1.7e9 + 1, 31.0, -111.0), Waypoint(1.7e9 + 2, 31.0001, -111.0))),
    Plan("ugv1", 1.7e9, ()),                                                    # an empty plan
    Crowds("loc1", "uav1", 1.7e9, "exact", ("ugv1",), (),
           (Crowd(1, 31.0, -111.0, (31.0,) * 4, (-111.0,) * 4, 1.0, 0.0, 0.5, "exact", 0),)),
    Status("ugv1", "ugv", 1.7e9, "up", 0, 3, 4, {"crowds_latency_p99_ms": 3.5}, "fine"),
    Status("ugv1", "ugv", 1.7e9, "none", 0, 0),                                 # defaults
]


def same(a, b) -> bool:
    """Equal values of the same types, arrays of the same dtype and shape."""
    if isinstance(a, np.ndarray):
        return isinstance(b, np.ndarray) and a.dtype == b.dtype and a.shape == b.shape and np.array_equal(a, b)
    if hasattr(a, "__dataclass_fields__"):
        return type(a) is type(b) and all(same(getattr(a, f), getattr(b, f)) for f in a.__dataclass_fields__)
    if isinstance(a, (tuple, list)):
        return type(a) is type(b) and len(a) == len(b) and all(map(same, a, b))
    if isinstance(a, dict):
        return type(b) is dict and a.keys() == b.keys() and all(same(a[k], b[k]) for k in a)
    return type(a) is type(b) and a == b


def agree(cls, raw: bytes) -> None:
    try:
        want = M._decode_checked(cls, raw)
    except MessageError as exc:
        want = exc
    try:
        got = M._fast_decoder(cls).attempt(raw)
    except M._FAST_REFUSALS:
        got = None
    if got is not None:   # accepted fast: the checked decoder accepts the same message
        assert not isinstance(want, MessageError), f"fast accepted what the checked decoder refuses: {want}"
        assert same(got, want), (got, want)
    try:
        res = decode(cls, raw)
    except MessageError as exc:
        assert isinstance(want, MessageError) and (exc.field, str(exc)) == (want.field, str(want))
    else:
        assert not isinstance(want, MessageError) and same(res, want)


@pytest.mark.parametrize("msg", VALID)
def test_valid_messages_decode_fast_and_alike(msg):
    raw = encode(msg)
    assert same(M._fast_decoder(type(msg)).attempt(raw), msg)
    agree(type(msg), raw)


NASTY = st.one_of(
    st.none(), st.booleans(), st.integers(-2 ** 63, 2 ** 64 - 1), st.sampled_from([0, -1, 1 << 53, (1 << 53) - 1]),
    st.floats(allow_nan=True, allow_infinity=True), st.sampled_from([-90.0, 90.0, 90.5, -180.0, 360.0, 359.99, 0.0, -0.0,
                                                                    1e10, 1e-300]),
    st.text(max_size=40), st.sampled_from(["", "ugv1", "abc\n", "**", "x" * 32, "x" * 33, "y" * 257, "exact", "ugv",
                                           "up", "great"]),
    st.binary(max_size=8),
    st.lists(st.floats(-1e3, 1e3), max_size=4), st.lists(st.lists(st.integers(-5, 5), max_size=5), max_size=3),
    st.lists(st.text(max_size=3), max_size=3), st.dictionaries(st.text(max_size=4), st.floats(), max_size=3),
)


def mutations(draw, data):
    """One field of the wire data (or of a nested map) replaced, removed or added."""
    if not isinstance(data, dict) or not data:
        return draw(NASTY)
    data = dict(data)
    key = draw(st.sampled_from(sorted(data)))
    how = draw(st.sampled_from(["replace", "replace", "nested", "remove", "add"]))
    if how == "replace":
        data[key] = draw(NASTY)
    elif how == "nested":
        v = data[key]
        if isinstance(v, dict):
            data[key] = mutations(draw, v)
        elif isinstance(v, list) and v:
            i = draw(st.integers(0, len(v) - 1))
            data[key] = [mutations(draw, x) if j == i else x for j, x in enumerate(v)]
        else:
            data[key] = draw(NASTY)
    elif how == "remove":
        del data[key]
    else:
        data[draw(st.sampled_from(["extra", "ugv", "vehicle", "schema"]))] = draw(NASTY)
    return data


@settings(max_examples=1500, deadline=None)
@given(st.data())
def test_mutated_payloads_are_judged_alike(data):
    msg = data.draw(st.sampled_from(VALID))
    wire = msgpack.unpackb(encode(msg))
    mutated = mutations(data.draw, wire["data"])
    agree(type(msg), msgpack.packb({"schema": wire["schema"], "data": mutated}))


@pytest.mark.parametrize(
    "raw",
    [
        msgpack.packb({"schema": "detections/4", "data": {**msgpack.unpackb(encode(DET))["data"],
                                                          "vehicle": "uav1"}}),  # a plain copy
        # a repeated key: msgpack and msgspec both keep the last; over 512 entries msgpack's limit refuses it
        b"\x82\xa6schema\xacdetections/4\xa4data\xde\x02\x01" + b"\xa7vehicle\xa4uav1" * 513,
        msgpack.packb({"schema": "detections/4", "data": {"blobs": [[[0]] * 9_000] * 2}}),   # a small bomb
    ],
)
def test_edge_payloads_are_judged_alike(raw):
    agree(Detections, raw)


def test_fast_decoding_is_used_for_the_hot_messages():
    for cls in (Fix, Detections, Crowds, Status, Plan):
        assert M._fast_decoder(cls) is not None, cls
    assert M._fast_decoder(M.Frame) is None     # a frame's bytes: one copy either way
    assert math.isfinite(decode(Detections, encode(DET)).stamp_s)
