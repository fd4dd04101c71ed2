"""Every message on the bus, declared once. MessagePack on the wire, validated on decode.

Wire form: a msgpack map ``{"schema": "<name>/<version>", "data": {field: value, ...}}``; arrays are
lists. :func:`decode` checks the schema name and version, that every declared field is present and no
other, each value's type, that every float is finite (a NaN never reaches the map), and ranges read
off the unit and frame in the field's name (``lat_deg`` in [-90, 90], ``lon_deg`` in [-180, 180],
``heading_deg`` in [0, 360), ``*_acc_m``/``radius95_m`` >= 0, ``stamp_s`` > 0). A failure raises
:class:`uvteam.errors.MessageError` naming the field, what was expected and what came.
"""

from __future__ import annotations

import math
import types
import typing
from dataclasses import MISSING, asdict, dataclass, fields, is_dataclass
from functools import cache
from typing import Any, ClassVar, TypeVar

import msgpack

from .errors import MessageError

__all__ = [
    "Fix", "Waypoint", "Plan", "Landmark", "Blob", "Detections", "Frame", "Person", "PeopleSeen", "Crowd",
    "Crowds", "TruthCrowd", "TruthUgv", "Truth", "Status", "encode", "decode", "MESSAGE_TYPES",
    "ENCODING",
]

ENCODING = "application/msgpack"
MAX_PAYLOAD_BYTES = 8 << 20   # a raw 1920x1080 BGR frame is 6.2 MB


@dataclass(frozen=True, slots=True)
class Fix:
    """A vehicle's GNSS fix and heading. Key: uvteam/<team>/<vehicle>/fix."""

    SCHEMA: ClassVar[str] = "fix/1"
    vehicle: str
    stamp_s: float          # capture time, UNIX epoch seconds
    lat_deg: float
    lon_deg: float
    alt_amsl_m: float
    heading_deg: float      # 0 = north, clockwise
    h_acc_m: float          # 1-sigma horizontal accuracy
    v_east_m_s: float = 0.0
    v_north_m_s: float = 0.0


@dataclass(frozen=True, slots=True)
class Waypoint:
    SCHEMA: ClassVar[str] = "waypoint/1"
    stamp_s: float          # when the vehicle plans to be there
    lat_deg: float
    lon_deg: float


@dataclass(frozen=True, slots=True)
class Plan:
    """A UGV's planned waypoints for the next tracking interval. Key: uvteam/<team>/<vehicle>/plan."""

    SCHEMA: ClassVar[str] = "plan/1"
    vehicle: str
    stamp_s: float          # when the plan was made
    waypoints: tuple[Waypoint, ...]


@dataclass(frozen=True, slots=True)
class Landmark:
    SCHEMA: ClassVar[str] = "landmark/1"
    ugv: str                # which UGV's roof color
    x_px: float
    y_px: float


@dataclass(frozen=True, slots=True)
class Blob:
    SCHEMA: ClassVar[str] = "blob/1"
    x_px: float             # centre
    y_px: float
    x0_px: float            # box, origin top-left
    y0_px: float
    x1_px: float
    y1_px: float
    v_x_px_s: float = 0.0
    v_y_px_s: float = 0.0
    ugv: str = ""           # the UGV this blob is, when the detector saw its roof label in it; else ""
    area_px: float = 1.0    # moving pixels; the localizer weights the parts of one crowd by it


@dataclass(frozen=True, slots=True)
class Detections:
    """One UAV frame's color landmarks and motion blobs. Key: uvteam/<team>/<uav>/detections."""

    SCHEMA: ClassVar[str] = "detections/1"
    vehicle: str
    stamp_s: float          # the frame's capture time
    frame_seq: int
    width_px: int
    height_px: int
    alt_agl_m: float
    landmarks: tuple[Landmark, ...]
    blobs: tuple[Blob, ...]


@dataclass(frozen=True, slots=True)
class Frame:
    """One camera frame with its capture time. Key: uvteam/<team>/<vehicle>/frame.

    ``encoding`` "jpeg" (``data`` is a JPEG file) or "bgr8" (``data`` is height x width x 3 bytes, row
    major); decoding the pixels is :func:`uvteam.frames.frame_pixels`, which checks the size."""

    SCHEMA: ClassVar[str] = "frame/1"
    vehicle: str
    stamp_s: float          # capture time, UNIX seconds
    frame_seq: int
    width_px: int
    height_px: int
    encoding: str
    data: bytes


@dataclass(frozen=True, slots=True)
class Person:
    SCHEMA: ClassVar[str] = "person/1"
    lat_deg: float
    lon_deg: float
    distance_m: float
    bearing_deg: float


@dataclass(frozen=True, slots=True)
class PeopleSeen:
    """People geolocated by a UGV's forward camera. Key: uvteam/<team>/<ugv>/people."""

    SCHEMA: ClassVar[str] = "people/1"
    vehicle: str
    stamp_s: float
    people: tuple[Person, ...]


@dataclass(frozen=True, slots=True)
class Crowd:
    SCHEMA: ClassVar[str] = "crowd/1"
    crowd_id: int
    lat_deg: float
    lon_deg: float
    footprint_lat_deg: tuple[float, ...]   # box corners mapped to the ground
    footprint_lon_deg: tuple[float, ...]
    v_east_m_s: float
    v_north_m_s: float
    radius95_m: float
    quality: str                            # uvteam.homography.FitQuality value
    n_outliers: int


@dataclass(frozen=True, slots=True)
class Crowds:
    """Geolocated crowds of one UAV frame. Key: uvteam/<team>/<uav>/crowds."""

    SCHEMA: ClassVar[str] = "crowds/1"
    vehicle: str
    stamp_s: float          # the frame's capture time
    quality: str
    landmarks_used: tuple[str, ...]
    outlier_landmarks: tuple[str, ...]
    crowds: tuple[Crowd, ...]


@dataclass(frozen=True, slots=True)
class TruthCrowd:
    SCHEMA: ClassVar[str] = "truth_crowd/1"
    lat_deg: float
    lon_deg: float
    members: int


@dataclass(frozen=True, slots=True)
class TruthUgv:
    SCHEMA: ClassVar[str] = "truth_ugv/1"
    vehicle: str
    lat_deg: float
    lon_deg: float


@dataclass(frozen=True, slots=True)
class Truth:
    """Simulation ground truth at a frame's capture time. Key: uvteam/<team>/sim/truth."""

    SCHEMA: ClassVar[str] = "truth/1"
    stamp_s: float
    frame_seq: int
    crowds: tuple[TruthCrowd, ...]
    ugvs: tuple[TruthUgv, ...]


@dataclass(frozen=True, slots=True)
class Status:
    """A service's health. Key: uvteam/<team>/<vehicle>/status."""

    SCHEMA: ClassVar[str] = "status/1"
    vehicle: str
    service: str
    stamp_s: float
    link: str                       # autopilot link state: "up", "down", "none"
    rejected: int                   # bad messages dropped since start
    published: int
    received: int = 0               # good messages received since start
    note: str = ""                  # free text, e.g. "latency_p50_ms=3.1 latency_p99_ms=9.8"


MESSAGE_TYPES = (Fix, Waypoint, Plan, Landmark, Blob, Detections, Frame, Person, PeopleSeen, Crowd, Crowds,
                 TruthCrowd, TruthUgv, Truth, Status)
T = TypeVar("T")


def _to_wire(v: Any) -> Any:
    if is_dataclass(v):
        return {f.name: _to_wire(getattr(v, f.name)) for f in fields(v)}
    if isinstance(v, (tuple, list)):
        return [_to_wire(x) for x in v]
    if hasattr(v, "item"):  # numpy scalar
        return v.item()
    return v


def encode(msg: Any) -> bytes:
    """Message -> bytes. Refuses to send what decode would refuse (never a NaN on the wire)."""
    wire = {"schema": type(msg).SCHEMA, "data": _to_wire(msg)}
    raw = msgpack.packb(wire, use_bin_type=True)
    decode(type(msg), raw)  # the same validation as the receiver: fail at the sender
    return raw


def _range_check(schema: str, name: str, v: float) -> None:
    def bad(why: str) -> MessageError:
        return MessageError(schema, name, f"{why}, got {v!r}")

    if not math.isfinite(v):
        raise bad("expected a finite number")
    if name.startswith("lat_deg") or name.endswith("lat_deg"):
        if not -90.0 <= v <= 90.0:
            raise bad("expected latitude in [-90, 90]")
    elif name.startswith("lon_deg") or name.endswith("lon_deg"):
        if not -180.0 <= v <= 180.0:
            raise bad("expected longitude in [-180, 180]")
    elif name in ("heading_deg", "bearing_deg"):
        if not 0.0 <= v < 360.0:
            raise bad("expected a heading in [0, 360)")
    elif name.endswith("_acc_m") or name in ("radius95_m", "distance_m", "alt_agl_m"):
        if v < 0.0:
            raise bad("expected a non-negative distance")
    elif name == "stamp_s":
        if v <= 0.0:
            raise bad("expected a UNIX time > 0")


@cache
def _hints(cls: type) -> dict[str, Any]:
    return typing.get_type_hints(cls)


def _check_value(schema: str, name: str, tp: Any, v: Any) -> Any:
    origin = typing.get_origin(tp)
    if tp is float:
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise MessageError(schema, name, f"expected a number, got {type(v).__name__}")
        v = float(v)
        _range_check(schema, name, v)
        return v
    if tp is int:
        if isinstance(v, bool) or not isinstance(v, int):
            raise MessageError(schema, name, f"expected an integer, got {type(v).__name__}")
        return v
    if tp is bytes:
        if not isinstance(v, (bytes, bytearray)):
            raise MessageError(schema, name, f"expected bytes, got {type(v).__name__}")
        return bytes(v)
    if tp is str:
        if not isinstance(v, str):
            raise MessageError(schema, name, f"expected a string, got {type(v).__name__}")
        if len(v) > 256:
            raise MessageError(schema, name, f"string longer than 256 characters ({len(v)})")
        return v
    if origin is tuple:
        (inner, _ell) = typing.get_args(tp)
        if not isinstance(v, (list, tuple)):
            raise MessageError(schema, name, f"expected a list, got {type(v).__name__}")
        if len(v) > 10_000:
            raise MessageError(schema, name, f"list too long ({len(v)})")
        return tuple(_check_value(schema, f"{name}", inner, x) if not is_dataclass(inner)
                     else _from_wire(inner, x, f"{schema}.{name}") for x in v)
    if isinstance(tp, type) and is_dataclass(tp):
        return _from_wire(tp, v, f"{schema}.{name}")
    if origin in (types.UnionType, typing.Union):
        raise MessageError(schema, name, "union types are not supported on the wire")
    raise MessageError(schema, name, f"unsupported field type {tp!r}")


def _from_wire(cls: type[T], data: Any, schema: str) -> T:
    if not isinstance(data, dict):
        raise MessageError(schema, "<data>", f"expected a map, got {type(data).__name__}")
    hints = _hints(cls)
    names = [f.name for f in fields(cls)]
    extra = set(data) - set(names)
    if extra:
        raise MessageError(schema, sorted(map(str, extra))[0], "unknown field")
    kw = {}
    for f in fields(cls):
        if f.name not in data:
            if f.default is not MISSING or f.default_factory is not MISSING:  # optional on the wire
                continue
            raise MessageError(schema, f.name, "missing")
        kw[f.name] = _check_value(schema, f.name, hints[f.name], data[f.name])
    return cls(**kw)


def decode(cls: type[T], raw: bytes) -> T:
    """Bytes -> a validated message of type ``cls`` or MessageError."""
    schema = getattr(cls, "SCHEMA", cls.__name__)
    if len(raw) > MAX_PAYLOAD_BYTES:
        raise MessageError(schema, "<payload>", f"payload of {len(raw)} bytes is too large")
    try:
        wire = msgpack.unpackb(raw, raw=False, strict_map_key=True)
    except Exception as exc:  # msgpack raises several unrelated types for bad input
        raise MessageError(schema, "<payload>", f"not MessagePack: {exc}") from None
    if not isinstance(wire, dict) or "schema" not in wire or "data" not in wire:
        raise MessageError(schema, "<envelope>", "expected {schema, data}")
    got = wire["schema"]
    if not isinstance(got, str) or "/" not in got:
        raise MessageError(schema, "schema", f"expected 'name/version', got {got!r}")
    name, _, version = got.partition("/")
    want_name, _, want_version = schema.partition("/")
    if name != want_name:
        raise MessageError(schema, "schema", f"expected {want_name!r}, got {name!r}")
    if version != want_version:
        raise MessageError(schema, "schema", f"unsupported version {version!r} (this build reads {want_version})")
    return _from_wire(cls, wire["data"], schema)


def as_dict(msg: Any) -> dict:
    """A message as plain data (for JSON output)."""
    return {"schema": type(msg).SCHEMA, **asdict(msg)}


__all__ += ["as_dict"]


# which message each topic carries (keys.TOPICS)
BY_TOPIC = {"fix": Fix, "plan": Plan, "detections": Detections, "sensor": Detections, "people": PeopleSeen,
            "crowds": Crowds, "status": Status, "truth": Truth, "frame": Frame}
__all__ += ["BY_TOPIC"]
