"""The published protocol: the committed JSON Schemas and reference are what the code generates, real
messages validate against them (jsonschema, an independent validator), and the schemas refuse what
the codec refuses."""

import base64
import copy
import json
from pathlib import Path

import jsonschema
import msgpack
import numpy as np
import pytest
from referencing import Registry, Resource

from uvteam import protocol
from uvteam.blobs import Blobs, Landmarks
from uvteam.errors import MessageError
from uvteam.messages import (Crowd, Crowds, Detections, Fix, Frame, PeopleSeen, Person, Plan, Status, Truth,
                             TruthCrowd, TruthUgv, Waypoint, decode, encode)
from uvteam_ground.protocol import main as protocol_main

ROOT = Path(__file__).resolve().parents[2]
SCHEMAS = ROOT / "docs" / "schemas"
T = 1.7646e9

SAMPLES = [
    Fix("ugv1", T, 31.485, -111.544, 1300.0, 90.0, 0.8, 1.0, -0.5, 3),
    Fix("ugv2", T, -33.9, 151.2, 20.0, None, 2.5),                           # unknown heading, velocity, fix type
    Plan("ugv1", T, (Waypoint(T + 1, 31.0, -111.0), Waypoint(T + 2, 31.0001, -111.0))),
    Plan("ugv1", T, ()),                                                      # no waypoints
    Detections("uav1", T, 3, 1280, 720, 50.0, 790.0, Landmarks(("ugv1",), np.array([[10.5, 20.0]])),
               Blobs(np.array([[100.0, 100], [5, 6]]), np.array([[90.0, 90, 110, 110], [1, 2, 9, 10]]),
                     np.array([40.0, 12.0]), ("ugv1", "")), 0.5, 4.0, 6.3),
    Detections("uav1", T, 4, 1280, 720, 50.0, 790.0, Landmarks(), Blobs.empty(), 0.5, 4.0, 6.3),   # nothing seen
    Frame("uav1", T, 7, 2, 1, "bgr8", bytes(range(6))),
    PeopleSeen("ugv3", T, (Person(31.0, -111.0, 12.5, 359.9),)),
    Crowds("loc1", "uav1", T, "robust", ("ugv1", "ugv2", "ugv3", "ugv4"), ("ugv5",),
           (Crowd(1, 31.0, -111.0, (31.0,) * 4, (-111.0,) * 4, 1.0, 0.0, 0.5, "exact", 0),)),
    Crowds("loc1", "uav1", T, "failed", (), (), ()),
    Status("ugv1", "ugv", T, "up", 0, 3, 4, {"crowds_latency_p99_ms": 3.5}, "fine"),
    Status("loc1", "localizer", T, "none", 1, 2),                             # defaults left out
    Truth(T, 9, (TruthCrowd(31.0, -111.0, 12),), (TruthUgv("ugv1", 31.0, -111.0),)),
]


def validator(cls) -> jsonschema.protocols.Validator:
    schema = json.loads((SCHEMAS / protocol.file_name(cls)).read_text())
    v = jsonschema.Draft202012Validator(schema, format_checker=jsonschema.FormatChecker())
    return v


def wire_data(raw: bytes) -> dict:
    """The msgpack data map as a third party gets it, bytes as base64 (JSON has none)."""
    data = msgpack.unpackb(raw)["data"]
    return {k: base64.b64encode(v).decode() if isinstance(v, bytes) else v for k, v in data.items()}


def test_committed_files_are_what_the_code_generates(capsys):
    # fails when a message changed and `uvteam protocol --json-schema docs/schemas --markdown docs/protocol.md`
    # was not run
    assert protocol_main(["--json-schema", str(SCHEMAS), "--markdown", str(ROOT / "docs" / "protocol.md"),
                          "--check"]) == 0, capsys.readouterr().err


def test_check_notices_a_stale_file(tmp_path, capsys):
    protocol_main(["--json-schema", str(tmp_path)])
    (tmp_path / "fix-2.schema.json").write_text("{}")
    assert protocol_main(["--json-schema", str(tmp_path), "--check"]) == 1
    assert "fix-2.schema.json" in capsys.readouterr().err


def test_every_schema_is_a_valid_draft_2020_12_schema():
    for name, schema in protocol.all_schemas().items():
        jsonschema.Draft202012Validator.check_schema(schema)


@pytest.mark.parametrize("msg", SAMPLES, ids=[f"{type(m).SCHEMA}-{i}" for i, m in enumerate(SAMPLES)])
def test_real_messages_validate_in_both_forms(msg):
    raw = encode(msg)
    v = validator(type(msg))
    v.validate(protocol.to_json(decode(type(msg), raw)))        # as_dict's form, as uvteam tap prints it
    v.validate(wire_data(raw))                                   # the msgpack data map as it is on the wire
    json.dumps(protocol.to_json(msg), allow_nan=False)           # and it is JSON


def test_the_envelope_schema_dispatches_on_the_schema_name():
    registry = Registry().with_resources(
        (s["$id"], Resource.from_contents(s)) for s in protocol.all_schemas().values())
    env = jsonschema.Draft202012Validator(protocol.envelope_schema(), registry=registry)
    crowds = next(m for m in SAMPLES if isinstance(m, Crowds))
    good = {"schema": "crowds/3", "data": wire_data(encode(crowds))}
    env.validate(good)
    assert not env.is_valid({"schema": "fix/2", "data": good["data"]})      # a crowds map is no fix
    assert not env.is_valid({"schema": "crowds/9", "data": good["data"]})   # an unknown version
    assert not env.is_valid({**good, "extra": 1})


FIX = wire_data(encode(SAMPLES[0]))
CROWDS = wire_data(encode(SAMPLES[8]))
DET = wire_data(encode(SAMPLES[4]))
STATUS = wire_data(encode(SAMPLES[10]))


def _with(base: dict, path: tuple, value) -> dict:
    d = copy.deepcopy(base)
    node = d
    for p in path[:-1]:
        node = node[p]
    if value is KeyError:
        del node[path[-1]]
    else:
        node[path[-1]] = value
    return d


# (message type, data map, whether the codec takes it): the schema must say the same
CASES = [
    (Fix, FIX, True),                                               # the sample itself
    (Fix, _with(FIX, ("lat_deg",), 90.0), True),                    # a pole is a latitude
    (Fix, _with(FIX, ("lat_deg",), 90.5), False),                   # beyond it is not
    (Fix, _with(FIX, ("lon_deg",), -180.01), False),                # longitude out of range
    (Fix, _with(FIX, ("heading_deg",), 360.0), False),              # a heading wraps below 360
    (Fix, _with(FIX, ("heading_deg",), None), True),                # unknown heading
    (Fix, _with(FIX, ("h_acc_m",), -0.1), False),                   # negative accuracy
    (Fix, _with(FIX, ("stamp_s",), 0.0), False),                    # no time
    (Fix, _with(FIX, ("stamp_s",), 1e10), False),                   # the year 2286
    (Fix, _with(FIX, ("vehicle",), "ugv 1"), False),                # not an id
    (Fix, _with(FIX, ("vehicle",), "ugv1\n"), False),               # a trailing newline is no id either
    (Fix, _with(FIX, ("vehicle",), "x" * 33), False),               # too long an id
    (Fix, _with(FIX, ("fix_type",), 9), False),                     # no such GPS fix type
    (Fix, _with(FIX, ("fix_type",), -1), False),                    # integers are >= 0
    (Fix, _with(FIX, ("alt_amsl_m",), 20000.5), False),             # the message's own altitude bound
    (Fix, _with(FIX, ("extra",), 1), False),                        # no unknown field
    (Fix, _with(FIX, ("h_acc_m",), KeyError), False),               # no missing field
    (Fix, _with(_with(FIX, ("v_east_m_s",), KeyError), ("v_north_m_s",), KeyError), True),   # optional fields
    (Fix, _with(FIX, ("v_east_m_s",), KeyError), False),            # half a velocity: a rule JSON Schema cannot
    #                                                                 state (x-rules), checked below
    (Crowds, _with(CROWDS, ("quality",), "great"), False),          # quality from the vocabulary
    (Crowds, _with(CROWDS, ("crowds", 0, "quality"), "great"), False),   # ... in a crowd too
    (Crowds, _with(CROWDS, ("crowds", 0, "crowd_id"), 1.5), False),  # ids are integers
    (Crowds, _with(CROWDS, ("crowds", 0, "footprint_lat_deg"), [31.0] * 65), False),   # at most 64 corners
    (Crowds, _with(CROWDS, ("crowds", 0, "footprint_lat_deg", 0), 95.0), False),       # a corner's latitude
    (Detections, _with(DET, ("blobs", "xyxy_px", 0), [1.0, 2.0, 3.0]), False),        # a box has 4 numbers
    (Detections, _with(DET, ("focal_px",), 0.0), False),            # a focal length > 0
    (Detections, _with(DET, ("sigma_color_px",), -1.0), False),     # sigmas >= 0
    (Status, _with(STATUS, ("service",), "toaster"), False),        # services from the vocabulary
    (Status, _with(STATUS, ("link",), "maybe"), False),             # up, down or none
    (Status, _with(STATUS, ("metrics", "a b"), 1.0), False),        # metric names are ids
    (Status, _with(STATUS, ("note",), "n" * 257), False),           # strings <= 256 characters
]


@pytest.mark.parametrize("cls, data, ok", CASES)
def test_the_schema_refuses_what_the_codec_refuses(cls, data, ok):
    raw = msgpack.packb({"schema": cls.SCHEMA, "data": data}, use_bin_type=True)
    try:
        decode(cls, raw)
        codec_ok = True
    except MessageError:
        codec_ok = False
    assert codec_ok == ok
    if ok or cls is not Fix or "v_east_m_s" in data:
        assert validator(cls).is_valid(data) == ok, list(validator(cls).iter_errors(data))[:1]
    else:   # the one cross-field rule in this table: the schema lists it under x-rules
        assert any(r["message"] == "velocity is both or neither" for r in protocol.json_schema(Fix)["x-rules"])


def test_rules_read_from_the_source():
    crowds = protocol.json_schema(Crowds)
    assert crowds["properties"]["quality"]["enum"] == ["exact", "least_squares", "robust", "suspect", "held", "pose", "failed"]
    assert crowds["x-zenoh-encoding"] == "application/msgpack;crowds/3"
    fr = protocol.json_schema(Frame)["properties"]
    assert fr["encoding"]["enum"] == ["jpeg", "bgr8"] and fr["width_px"]["maximum"] == 8192
    fix = protocol.json_schema(Fix)["properties"]
    assert fix["heading_deg"]["description"] == "0 = north, clockwise; None = unknown"   # the field's comment
    det = protocol.json_schema(Detections)
    assert any(r["message"] == "at most 2000 blobs in a frame" for r in det["x-rules"])   # blobs is no array
    assert det["$defs"]["blobs"]["properties"]["xyxy_px"]["x-shape"] == ["N", 4]
