"""Every message on the bus, declared once. MessagePack on the wire, validated on decode.

Wire form: a msgpack map ``{"schema": "<name>/<version>", "data": {field: value, ...}}``; arrays are
lists (an (N, k) array is N lists of k numbers). :func:`decode` checks, and a failure raises
:class:`uvteam.errors.MessageError` naming the field, what was expected and what came:

- the envelope, the schema name and version, the payload's size (``MAX_BYTES`` per message; msgpack is
  unpacked with length limits, so a hostile payload costs at most a few times its size to refuse);
- every declared field present (unless it has a default) and no other, each value's type;
- every number finite (a NaN never reaches the map), integers whole and >= 0, strings <= 256
  characters, lists <= ``MAX_LIST``;
- ranges read off the unit and frame in the field's name: ``lat_deg`` in [-90, 90], ``lon_deg`` in
  [-180, 180], ``heading_deg``/``bearing_deg`` in [0, 360), ``*_acc_m``/``radius95_m``/``distance_m``/
  ``alt_agl_m``/``sigma_*`` >= 0, ``stamp_s`` a UNIX time in (0, 1e10);
- ids (``vehicle``, ``uav``, ``ugv``, landmark names) are 1-32 characters of [A-Za-z0-9_-] (:mod:`uvteam.vocab`);
- each message's own rules (``_rules``): parallel lists of one length, boxes with x0 <= x1, a frame's
  bytes that make its stated image, a quality that is a :class:`uvteam.vocab.FitQuality`, ...

:func:`encode` refuses what :func:`decode` would refuse: the sender fails, not the receiver. The
schema name travels in zenoh's encoding too (``application/msgpack;<schema>``).
"""

from __future__ import annotations

import math
import types
import typing
from dataclasses import MISSING, dataclass, field, fields, is_dataclass
from functools import cache
from typing import Annotated, Any, Callable, ClassVar, TypeVar

import msgpack
import numpy as np

from .blobs import Blobs, Columns, Landmarks
from .errors import MessageError
from .vocab import QUALITIES, SERVICES, is_id

__all__ = [
    "Fix", "Waypoint", "Plan", "CameraPoseReport", "Detections", "Frame", "Person", "PeopleSeen", "Crowd", "Crowds", "TruthCrowd",
    "TruthUgv", "Truth", "Status", "encode", "decode", "as_dict", "MESSAGE_TYPES", "BY_TOPIC", "ENCODING",
    "encoding_of", "MAX_LIST", "MAX_BLOBS", "field_range",
]

ENCODING = "application/msgpack"
MAX_LIST = 10_000
MAX_BLOBS = 2_000            # blobs in one frame: a crowd scene has tens; more is a broken or hostile sender
MAX_STAMP_S = 1e10           # the year 2286: a stamp beyond is garbage
MAX_STR_LEN = 256            # characters in a string
MAX_MAP_LEN = 256            # entries in a map (Status.metrics)
MAX_INT = 1 << 53            # integers are in [0, 2^53): exact in a double, so in JSON too
FRAME_ENCODINGS = ("jpeg", "bgr8")


def encoding_of(cls: type) -> str:
    """zenoh's encoding string for a message type, naming its schema: ``application/msgpack;crowds/2``."""
    return f"{ENCODING};{cls.SCHEMA}"


def _rule(ok: bool, name: str, why: str) -> None:
    if not ok:
        raise ValueError(f"{name}\x00{why}")


@dataclass(frozen=True, slots=True)
class Fix:
    """A vehicle's GNSS fix and heading. Key: uvteam/<team>/<vehicle>/fix. Unknown is None, never 0."""

    SCHEMA: ClassVar[str] = "fix/2"
    MAX_BYTES: ClassVar[int] = 1024
    vehicle: str
    stamp_s: float                      # capture time, UNIX epoch seconds
    lat_deg: float
    lon_deg: float
    alt_amsl_m: float
    heading_deg: float | None           # 0 = north, clockwise; None = unknown
    h_acc_m: float                      # 1-sigma horizontal accuracy (a cautious value when the receiver gives none)
    v_east_m_s: float | None = None     # the receiver's velocity; None = unknown
    v_north_m_s: float | None = None
    fix_type: int | None = None         # GPS fix type (MAVLink GPS_FIX_TYPE: 3 = 3D); None = unknown

    def _rules(self) -> None:
        _rule((self.v_east_m_s is None) == (self.v_north_m_s is None), "v_north_m_s", "velocity is both or neither")
        _rule(self.fix_type is None or self.fix_type <= 8, "fix_type", "expected a GPS_FIX_TYPE in 0-8")
        _rule(-1000.0 <= self.alt_amsl_m <= 20000.0, "alt_amsl_m", "expected an altitude in [-1000, 20000] m")


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
    MAX_BYTES: ClassVar[int] = 64 << 10
    vehicle: str
    stamp_s: float          # when the plan was made
    waypoints: tuple[Waypoint, ...]

    def _rules(self) -> None:
        s = [w.stamp_s for w in self.waypoints]
        _rule(all(a <= b for a, b in zip(s, s[1:])), "waypoints", "waypoint times must not go backwards")


@dataclass(frozen=True, slots=True)
class CameraPoseReport:
    """Where the UAV camera was and how it looked at a frame's capture time, as the autopilot and the
    gimbal report it, with what each value is worth (1-sigma). ``yaw_deg``: the image top, clockwise
    from north; ``roll_deg``/``pitch_deg``: the optical axis' tilt from straight down."""

    SCHEMA: ClassVar[str] = "camera_pose/1"
    lat_deg: float
    lon_deg: float
    alt_agl_m: float
    roll_deg: float
    pitch_deg: float
    yaw_deg: float
    sigma_position_m: float
    sigma_attitude_deg: float
    sigma_yaw_deg: float
    sigma_alt_m: float

    def _rules(self) -> None:
        _rule(-90.0 <= self.roll_deg <= 90.0 and -90.0 <= self.pitch_deg <= 90.0, "roll_deg",
              "expected roll and pitch in [-90, 90]")


@dataclass(frozen=True, slots=True, eq=False)
class Detections:
    """One UAV frame's roof-label landmarks and motion blobs, with what the detector's positions are
    worth (1-sigma per axis, pixels). Key: uvteam/<team>/<uav>/detections (UGV ids), and the simulator's
    .../sensor (roof colors, which the UAV service relabels)."""

    SCHEMA: ClassVar[str] = "detections/2"
    MAX_BYTES: ClassVar[int] = 192 << 10   # 2000 blobs take ~140 kB
    vehicle: str
    stamp_s: float              # the frame's capture time
    frame_seq: int
    width_px: int
    height_px: int
    alt_agl_m: float            # the UAV's height above ground the detector used
    focal_px: float             # the camera's focal length at this frame size
    landmarks: Landmarks
    blobs: Blobs
    sigma_color_px: float       # a roof label's centre
    sigma_ugv_blob_px: float    # a UGV's motion-blob centre
    sigma_crowd_blob_px: float  # a crowd's motion-blob centre, against its members' centroid
    pose: CameraPoseReport | None = None   # the camera's pose, when the UAV knows it

    def _rules(self) -> None:
        _rule(len(self.blobs) <= MAX_BLOBS, "blobs", f"at most {MAX_BLOBS} blobs in a frame, got {len(self.blobs)}")
        _rule(self.focal_px > 0, "focal_px", "expected a focal length > 0")
        _rule(all(is_id(u) for u in self.landmarks.ugv), "landmarks", "landmark names must be ids")
        _rule(all(u == "" or is_id(u) for u in self.blobs.ugv), "blobs", "blob labels must be ids or empty")

    def __eq__(self, other) -> bool:
        return isinstance(other, Detections) and all(getattr(self, f.name) == getattr(other, f.name) for f in fields(self))

    __hash__ = None  # type: ignore[assignment]


@dataclass(frozen=True, slots=True)
class Frame:
    """One camera frame with its capture time. Key: uvteam/<team>/<vehicle>/frame.

    ``encoding`` "jpeg" (``data`` is a JPEG file) or "bgr8" (``data`` is height x width x 3 bytes, row
    major); decoding the pixels is :func:`uvteam.frames.frame_pixels`."""

    SCHEMA: ClassVar[str] = "frame/1"
    MAX_BYTES: ClassVar[int] = 8 << 20   # a raw 1920x1080 BGR frame is 6.2 MB
    vehicle: str
    stamp_s: float          # capture time, UNIX seconds
    frame_seq: int
    width_px: int
    height_px: int
    encoding: str
    data: bytes

    def _rules(self) -> None:
        _rule(self.encoding in FRAME_ENCODINGS, "encoding", f"expected one of {', '.join(FRAME_ENCODINGS)}")
        _rule(0 < self.width_px <= 8192 and 0 < self.height_px <= 8192, "width_px", "expected 1-8192 x 1-8192 pixels")
        if self.encoding == "bgr8":
            n = self.width_px * self.height_px * 3
            _rule(len(self.data) == n, "data", f"a bgr8 {self.width_px}x{self.height_px} frame has {n} bytes, "
                                                f"got {len(self.data)}")


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
    MAX_BYTES: ClassVar[int] = 128 << 10
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
    quality: str                            # a uvteam.vocab.FitQuality value
    n_outliers: int

    def _rules(self) -> None:
        _rule(len(self.footprint_lat_deg) == len(self.footprint_lon_deg), "footprint_lon_deg",
              f"{len(self.footprint_lat_deg)} latitudes but {len(self.footprint_lon_deg)} longitudes")
        _rule(len(self.footprint_lat_deg) <= 64, "footprint_lat_deg", "at most 64 footprint corners")
        _rule(self.quality in QUALITIES, "quality", f"expected one of {', '.join(QUALITIES)}")


@dataclass(frozen=True, slots=True)
class Crowds:
    """Geolocated crowds of one UAV frame. Key: uvteam/<team>/<localizer>/crowds (the sender's own key)."""

    SCHEMA: ClassVar[str] = "crowds/2"
    MAX_BYTES: ClassVar[int] = 128 << 10
    vehicle: str                    # the localizer
    uav: str                        # whose frame
    stamp_s: float                  # the frame's capture time
    quality: str
    landmarks_used: tuple[str, ...]
    outlier_landmarks: tuple[str, ...]
    crowds: tuple[Crowd, ...]

    def _rules(self) -> None:
        _rule(self.quality in QUALITIES, "quality", f"expected one of {', '.join(QUALITIES)}")
        _rule(all(is_id(u) for u in self.landmarks_used + self.outlier_landmarks), "landmarks_used",
              "landmark names must be ids")
        _rule(len({c.crowd_id for c in self.crowds}) == len(self.crowds), "crowds", "crowd ids must be unique")


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
    MAX_BYTES: ClassVar[int] = 128 << 10
    stamp_s: float
    frame_seq: int
    crowds: tuple[TruthCrowd, ...]
    ugvs: tuple[TruthUgv, ...]


@dataclass(frozen=True, slots=True)
class Status:
    """A service's health, once a second. Key: uvteam/<team>/<vehicle>/status.

    ``metrics``: numbers by name (``crowds_published``, ``latency_p99_ms``, ...; each service documents
    its own); ``note``: free text for people, never parsed."""

    SCHEMA: ClassVar[str] = "status/2"
    MAX_BYTES: ClassVar[int] = 32 << 10
    vehicle: str
    service: str
    stamp_s: float
    link: str                       # autopilot link state: "up", "down", "none"
    rejected: int                   # bad messages dropped since start
    published: int
    received: int = 0               # good messages received since start
    metrics: dict[str, float] = field(default_factory=dict)
    note: str = ""

    def _rules(self) -> None:
        _rule(self.service in SERVICES, "service", f"expected one of {', '.join(SERVICES)}")
        _rule(self.link in ("up", "down", "none"), "link", "expected up, down or none")


MESSAGE_TYPES = (Fix, Waypoint, Plan, CameraPoseReport, Detections, Frame, Person, PeopleSeen, Crowd, Crowds, TruthCrowd, TruthUgv,
                 Truth, Status)
# which message each topic carries (uvteam.keys.TOPICS)
BY_TOPIC = {"fix": Fix, "plan": Plan, "detections": Detections, "sensor": Detections, "people": PeopleSeen,
            "crowds": Crowds, "status": Status, "truth": Truth, "frame": Frame}
ID_FIELDS = frozenset({"vehicle", "uav"})
T = TypeVar("T")
DEFAULT_MAX_BYTES = 64 << 10


# --- encoding ---------------------------------------------------------------------------------------
def _to_wire(v: Any) -> Any:
    if isinstance(v, np.ndarray):
        return v.tolist()
    if is_dataclass(v):
        return {f.name: _to_wire(getattr(v, f.name)) for f in fields(v)}
    if isinstance(v, (tuple, list)):
        return [_to_wire(x) for x in v]
    if isinstance(v, dict):
        return {k: _to_wire(x) for k, x in v.items()}
    if isinstance(v, np.generic):
        return v.item()
    return v


def encode(msg: Any) -> bytes:
    """Message -> bytes. Refuses to send what decode would refuse (never a NaN on the wire)."""
    raw = msgpack.packb({"schema": type(msg).SCHEMA, "data": _to_wire(msg)}, use_bin_type=True)
    decode(type(msg), raw)  # the same validation as the receiver: fail at the sender
    return raw


def as_dict(msg: Any) -> dict:
    """A message as plain data (JSON-ready: arrays as lists)."""
    return {"schema": type(msg).SCHEMA, **_to_wire(msg)}


# --- decoding: one checker per field, compiled once per message type --------------------------------
Checker = Callable[[str, Any], Any]


def field_range(name: str) -> tuple[float | None, float | None, bool, bool, str] | None:
    """The range a float field is held to, read off its name: ``(lo, hi, lo_closed, hi_closed, why)``
    (None for no bound), or None when the name implies none. The codec checks it; the published JSON
    Schemas (:mod:`uvteam.protocol`) state it."""
    if name.endswith("lat_deg"):
        return -90.0, 90.0, True, True, "expected latitude in [-90, 90]"
    if name.endswith("lon_deg"):
        return -180.0, 180.0, True, True, "expected longitude in [-180, 180]"
    if name in ("heading_deg", "bearing_deg", "yaw_deg"):
        return 0.0, 360.0, True, False, "expected a heading in [0, 360)"
    if name.endswith("_acc_m") or name.startswith("sigma_") or name in ("radius95_m", "distance_m", "alt_agl_m"):
        return 0.0, None, True, True, "expected a non-negative value"
    if name == "stamp_s":
        return 0.0, MAX_STAMP_S, False, False, f"expected a UNIX time in (0, {MAX_STAMP_S:.0e})"
    return None


def _range(schema: str, name: str) -> Callable[[float], None]:
    r = field_range(name)
    if r is None:
        return lambda v: None
    lo, hi, lo_closed, hi_closed, why = r

    def check(v: float) -> None:
        if (lo is not None and (v < lo if lo_closed else v <= lo)) or (hi is not None and (v > hi if hi_closed else v >= hi)):
            raise MessageError(schema, name, f"{why}, got {v!r}")
    return check


def _float(schema: str, name: str) -> Checker:
    in_range = _range(schema, name)

    def check(_s: str, v: Any) -> float:
        if v.__class__ is not float:
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                raise MessageError(schema, name, f"expected a number, got {type(v).__name__}")
            v = float(v)
        if not math.isfinite(v):
            raise MessageError(schema, name, f"expected a finite number, got {v!r}")
        in_range(v)
        return v
    return check


def _int(schema: str, name: str) -> Checker:
    def check(_s: str, v: Any) -> int:
        if v.__class__ is not int:
            raise MessageError(schema, name, f"expected an integer, got {type(v).__name__}")
        if not 0 <= v < MAX_INT:
            raise MessageError(schema, name, f"expected an integer in [0, 2^53), got {v}")
        return v
    return check


def _str(schema: str, name: str, is_ident: bool) -> Checker:
    def check(_s: str, v: Any) -> str:
        if v.__class__ is not str:
            raise MessageError(schema, name, f"expected a string, got {type(v).__name__}")
        if len(v) > MAX_STR_LEN:
            raise MessageError(schema, name, f"string longer than {MAX_STR_LEN} characters ({len(v)})")
        if is_ident and not is_id(v):
            raise MessageError(schema, name, f"expected an id (1-32 of A-Z a-z 0-9 _ -), got {v!r}")
        return v
    return check


def _bytes(schema: str, name: str) -> Checker:
    def check(_s: str, v: Any) -> bytes:
        if not isinstance(v, (bytes, bytearray)):
            raise MessageError(schema, name, f"expected bytes, got {type(v).__name__}")
        return bytes(v)
    return check


def _array(schema: str, name: str, cols: int) -> Checker:
    shape = (-1,) if cols == 0 else (-1, cols)

    def check(_s: str, v: Any) -> np.ndarray:
        if v.__class__ is not tuple:
            raise MessageError(schema, name, f"expected a list, got {type(v).__name__}")
        if len(v) > MAX_LIST:
            raise MessageError(schema, name, f"list too long ({len(v)})")
        if not v:
            return np.empty((0,) if cols == 0 else (0, cols))
        try:
            a = np.array(v)
        except (TypeError, ValueError):   # ragged rows
            a = None
        if a is None or a.dtype.kind not in "fiu" or a.shape != (len(v),) + shape[1:]:
            want = "numbers" if cols == 0 else f"rows of {cols} numbers"
            raise MessageError(schema, name, f"expected {want}, got {a.dtype if a is not None else 'ragged rows'} "
                                             f"{a.shape if a is not None else ''}".rstrip())
        a = a.astype(float)
        if not np.isfinite(a).all():
            raise MessageError(schema, name, "expected finite numbers")
        return a
    return check


def _optional(inner: Checker) -> Checker:
    def check(s: str, v: Any) -> Any:
        return None if v is None else inner(s, v)
    return check


def _tuple(schema: str, name: str, inner: Checker) -> Checker:
    def check(s: str, v: Any) -> tuple:
        if v.__class__ is not tuple:
            raise MessageError(schema, name, f"expected a list, got {type(v).__name__}")
        if len(v) > MAX_LIST:
            raise MessageError(schema, name, f"list too long ({len(v)})")
        return tuple(inner(s, x) for x in v)
    return check


def _mapping(schema: str, name: str, value: Checker) -> Checker:
    def check(s: str, v: Any) -> dict:
        if v.__class__ is not dict:
            raise MessageError(schema, name, f"expected a map, got {type(v).__name__}")
        if len(v) > MAX_MAP_LEN:
            raise MessageError(schema, name, f"map too long ({len(v)})")
        out = {}
        for k, x in v.items():
            if not is_id(k):
                raise MessageError(schema, name, f"expected names of 1-32 of A-Z a-z 0-9 _ -, got {k!r}")
            out[k] = value(s, x)
        return out
    return check


def _checker(schema: str, name: str, tp: Any) -> Checker:
    origin = typing.get_origin(tp)
    if origin is Annotated:
        base, *meta = typing.get_args(tp)
        cols = next((m.n for m in meta if isinstance(m, Columns)), None)
        if base is np.ndarray and cols is not None:
            return _array(schema, name, cols)
        return _checker(schema, name, base)
    if origin in (types.UnionType, typing.Union):
        args = [a for a in typing.get_args(tp) if a is not type(None)]
        if len(args) != 1 or len(typing.get_args(tp)) != 2:
            raise TypeError(f"{schema}.{name}: only 'X | None' unions go on the wire")
        return _optional(_checker(schema, name, args[0]))
    if tp is float:
        return _float(schema, name)
    if tp is int:
        return _int(schema, name)
    if tp is str:
        return _str(schema, name, name in ID_FIELDS)
    if tp is bytes:
        return _bytes(schema, name)
    if origin is tuple:
        inner, _ell = typing.get_args(tp)
        return _tuple(schema, name, _checker(schema, name, inner))
    if origin is dict:
        k, v = typing.get_args(tp)
        if k is not str:
            raise TypeError(f"{schema}.{name}: map keys must be str")
        return _mapping(schema, name, _checker(schema, name, v))
    if isinstance(tp, type) and is_dataclass(tp):
        sub = _decoder(tp)
        return lambda s, v: sub(v, f"{schema}.{name}")
    raise TypeError(f"{schema}.{name}: unsupported field type {tp!r}")


@cache
def _decoder(cls: type) -> Callable[[Any, str], Any]:
    """A function (wire data, schema label) -> a checked ``cls``, built once per type."""
    hints = typing.get_type_hints(cls, include_extras=True)
    schema = getattr(cls, "SCHEMA", cls.__name__)
    specs = []
    for f in fields(cls):
        required = f.default is MISSING and f.default_factory is MISSING
        specs.append((f.name, required, _checker(schema, f.name, hints[f.name])))
    names = frozenset(n for n, _, _ in specs)
    rules = getattr(cls, "_rules", None)

    def decode_data(data: Any, label: str) -> Any:
        if data.__class__ is not dict:
            raise MessageError(label, "<data>", f"expected a map, got {type(data).__name__}")
        if not names.issuperset(data):
            raise MessageError(label, sorted(map(str, set(data) - names))[0], "unknown field")
        kw = {}
        for name, required, check in specs:
            if name in data:
                kw[name] = check(label, data[name])
            elif required:
                raise MessageError(label, name, "missing")
        try:
            msg = cls(**kw)
            if rules is not None:
                rules(msg)
        except ValueError as exc:   # a type's own checks (Blobs) or its schema rules
            where, _, why = str(exc).partition("\x00")
            if not why:
                where, _, why = str(exc).partition(": ")
            raise MessageError(label, where if why else "<rules>", why or str(exc)) from None
        return msg
    return decode_data


def _limits(cls: type) -> dict:
    size = getattr(cls, "MAX_BYTES", DEFAULT_MAX_BYTES)
    has_lists = any(typing.get_origin(t) in (tuple, Annotated) or (isinstance(t, type) and is_dataclass(t))
                    for t in typing.get_type_hints(cls, include_extras=True).values())
    return {"max_bin_len": size, "max_str_len": 1 << 16,
            "max_array_len": MAX_LIST if has_lists else 16, "max_map_len": 512, "max_ext_len": 0}


@cache
def _unpack_limits(cls: type) -> tuple[int, dict]:
    return getattr(cls, "MAX_BYTES", DEFAULT_MAX_BYTES), _limits(cls)


def decode(cls: type[T], raw: bytes) -> T:
    """Bytes -> a validated message of type ``cls``, or MessageError."""
    schema = cls.SCHEMA
    max_bytes, limits = _unpack_limits(cls)
    if len(raw) > max_bytes:
        raise MessageError(schema, "<payload>", f"payload of {len(raw)} bytes is over {schema}'s {max_bytes}")
    try:
        # arrays as tuples: an empty one is a shared singleton, so a payload of empty arrays costs little
        wire = msgpack.unpackb(raw, raw=False, strict_map_key=True, use_list=False, **limits)
    except Exception as exc:  # msgpack raises several unrelated types for bad input
        raise MessageError(schema, "<payload>", f"not MessagePack within limits: {exc}") from None
    if wire.__class__ is not dict or "schema" not in wire or "data" not in wire or len(wire) != 2:
        raise MessageError(schema, "<envelope>", "expected {schema, data}")
    got = wire["schema"]
    if got != schema:
        if not isinstance(got, str) or "/" not in got:
            raise MessageError(schema, "schema", f"expected 'name/version', got {got!r}")
        name, _, version = got.partition("/")
        want_name, _, want_version = schema.partition("/")
        if name != want_name:
            raise MessageError(schema, "schema", f"expected {want_name!r}, got {name!r}")
        raise MessageError(schema, "schema", f"unsupported version {version!r} (this build reads {want_version})")
    return _decoder(cls)(wire["data"], schema)

