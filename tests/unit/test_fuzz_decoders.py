"""Fuzzing every decoder: valid messages with one value replaced by anything msgpack can carry, and
random payloads. Each either decodes to a message that keeps the schema's own rules (checked here
independently of the codec) or is refused with a MessageError; nothing else, never a crash.

Bounded for CI (UVTEAM_FUZZ_EXAMPLES per message type, 150 by default); `make fuzz` runs 5000."""

import math
import os
import re

import msgpack
import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from uvteam.blobs import Blobs, Landmarks
from uvteam.errors import MessageError
from uvteam.messages import (CameraPoseReport, Crowd, Crowds, Detections, Fix, Frame, PeopleSeen, Person, Plan, Status,
                             Truth, TruthCrowd, TruthUgv, Waypoint, decode, encode)
from uvteam.vocab import QUALITIES, SERVICES

EXAMPLES = int(os.environ.get("UVTEAM_FUZZ_EXAMPLES", "150"))
T = 1.7e9
ID = re.compile(r"^[A-Za-z0-9_-]{1,32}$")

SAMPLES = [
    Fix("ugv1", T, 31.4, -111.5, 1300.0, 90.0, 0.8, 1.0, -0.5, 3),
    Plan("ugv1", T, (Waypoint(T + 1, 31.0, -111.0), Waypoint(T + 2, 31.0001, -111.0))),
    Detections("uav1", T, 3, 1280, 720, 50.0, 790.0, Landmarks(("ugv1", "ugv2"), np.array([[10.0, 20.0], [30.0, 40.0]])),
               Blobs(np.array([[100.0, 100.0]]), np.array([[90.0, 90.0, 110.0, 110.0]]), np.array([40.0]), ("ugv1",)),
               0.5, 4.0, 6.0, CameraPoseReport(31.0, -111.0, 50.0, 1.0, -2.0, 10.0, 0.5, 1.0, 3.0, 1.0)),
    Frame("uav1", T, 1, 2, 2, "bgr8", b"\x00" * 12),
    PeopleSeen("ugv1", T, (Person(31.0, -111.0, 12.0, 80.0),)),
    Crowds("loc1", "uav1", T, "exact", ("ugv1",), (), (Crowd(1, 31.0, -111.0, (31.0,) * 4, (-111.0,) * 4, 1.0, 0.0, 0.5,
                                                              "exact", 0),)),
    Truth(T, 1, (TruthCrowd(31.0, -111.0, 15),), (TruthUgv("ugv1", 31.0, -111.0),)),
    Status("ugv1", "ugv", T, "up", 0, 3, 4, {"x": 1.5}, "note"),
]

anything = st.recursive(
    st.none() | st.booleans() | st.integers(-(2 ** 63), 2 ** 64 - 1) | st.floats(allow_nan=True, allow_infinity=True)
    | st.sampled_from(["", "**", "../x", "a" * 300, "ugv 1", "exact", "ugv1", "bgr8", "up"]) | st.binary(max_size=64),
    lambda inner: st.lists(inner, max_size=6) | st.dictionaries(st.text(max_size=8), inner, max_size=4),
    max_leaves=20)


def _paths(v, path=()):
    yield path
    if isinstance(v, dict):
        for k, x in v.items():
            yield from _paths(x, path + (k,))
    elif isinstance(v, list):
        for i, x in enumerate(v):
            yield from _paths(x, path + (i,))


def _replace(v, path, new):
    if not path:
        return new
    v = dict(v) if isinstance(v, dict) else list(v)
    v[path[0]] = _replace(v[path[0]], path[1:], new)
    return v


def _wire(msg):
    return msgpack.unpackb(encode(msg), raw=False)


def _keeps_the_rules(v, name="") -> None:
    """Independently of the codec: every number finite, the ranges and ids the schema states."""
    if isinstance(v, float):
        assert math.isfinite(v), name
        if name.endswith("lat_deg"):
            assert -90 <= v <= 90, name
        if name.endswith("lon_deg"):
            assert -180 <= v <= 180, name
        if name in ("heading_deg", "bearing_deg", "yaw_deg"):
            assert 0 <= v < 360, name
        if name == "stamp_s":
            assert 0 < v < 1e10, name
        if name.endswith("_acc_m") or name.startswith("sigma_") or name in ("radius95_m", "distance_m", "alt_agl_m"):
            assert v >= 0, name
    elif isinstance(v, bool):
        raise AssertionError(f"{name}: a bool where the schema has none")
    elif isinstance(v, int):
        assert 0 <= v < 2 ** 53, name
    elif isinstance(v, str):
        assert len(v) <= 256, name
        if name in ("vehicle", "uav"):
            assert ID.match(v), name
        if name == "quality":
            assert v in QUALITIES, name
        if name == "service":
            assert v in SERVICES, name
    elif isinstance(v, np.ndarray):
        assert np.isfinite(v).all(), name
    elif isinstance(v, (tuple, list)):
        for x in v:
            _keeps_the_rules(x, name)
    elif isinstance(v, dict):
        for k, x in v.items():
            assert ID.match(k), name
            _keeps_the_rules(x, name)
    elif hasattr(v, "__dataclass_fields__"):
        for f in v.__dataclass_fields__:
            _keeps_the_rules(getattr(v, f), f)
        if isinstance(v, Blobs):
            assert len(v.xy_px) == len(v.xyxy_px) == len(v.area_px) == len(v.ugv)
            assert (v.xyxy_px[:, 2] >= v.xyxy_px[:, 0]).all() and (v.xyxy_px[:, 3] >= v.xyxy_px[:, 1]).all()
            assert (v.area_px >= 0).all() and all(u == "" or ID.match(u) for u in v.ugv)
        if isinstance(v, Landmarks):
            assert len(v.ugv) == len(v.xy_px) == len(set(v.ugv)) and all(ID.match(u) for u in v.ugv)
        if isinstance(v, Crowd):
            assert len(v.footprint_lat_deg) == len(v.footprint_lon_deg)
        if isinstance(v, Frame) and v.encoding == "bgr8":
            assert len(v.data) == v.width_px * v.height_px * 3


def _check(cls, raw: bytes) -> None:
    try:
        msg = decode(cls, raw)
    except MessageError:
        return
    _keeps_the_rules(msg)


@settings(max_examples=EXAMPLES * len(SAMPLES), deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.sampled_from(SAMPLES), st.data(), anything)
def test_one_value_replaced_by_anything(sample, data, new):
    wire = _wire(sample)
    path = data.draw(st.sampled_from(list(_paths(wire))))
    raw = msgpack.packb(_replace(wire, path, new), use_bin_type=True)
    _check(type(sample), raw)


@settings(max_examples=EXAMPLES * 2, deadline=None)
@given(st.sampled_from(SAMPLES), st.binary(max_size=512))
def test_random_bytes_and_truncations(sample, junk):
    raw = encode(sample)
    for candidate in (junk, raw[: len(junk) % max(len(raw), 1)], raw + junk, junk + raw):
        _check(type(sample), candidate)
