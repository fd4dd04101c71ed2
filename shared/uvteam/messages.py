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

Two decoders, one set of rules. The checked decoder (:func:`_decode_checked`: msgpack unpacked with
limits, one compiled checker per field) is the reference and the only one that explains a refusal. The
fast one (:func:`_fast_decoder`) is generated once per message type from the same dataclasses: msgspec
decodes straight into typed structs whose constraints are the checked decoder's (types, finiteness,
ranges by name, string and list lengths, unknown fields), then the arrays and dataclasses are built and
the message's ``_rules`` run. Whatever the fast decoder cannot accept falls through to the checked one,
which accepts it or raises the error naming the field: a payload is accepted by both or refused with the
same :class:`MessageError` (``tests/unit/test_messages.py`` checks the two agree on mutated payloads).
A Detections message of 20 blobs decodes in ~5-10 us instead of ~80 us (``uvteam bench codec``).
"""

from __future__ import annotations

import itertools
import math
import sys
import types
import typing
from dataclasses import MISSING, dataclass, field, fields, is_dataclass
from functools import cache
from typing import Annotated, Any, Callable, ClassVar, TypeVar

import msgpack
import msgspec
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
    """zenoh's encoding string for a message type, naming its schema: ``application/msgpack;crowds/3``."""
    return f"{ENCODING};{cls.SCHEMA}"


def _rule(ok: bool, name: str, why: str) -> None:
    if not ok:
        raise ValueError(f"{name}\x00{why}")


# Strings already found to be ids (:func:`uvteam.vocab.is_id`), and labels (an id or ""): every message
# repeats the same few, and a set lookup is ~20x cheaper than the pattern. Bounded: cleared when full.
_IDS_SEEN: set = set()
_LABELS_SEEN: set = {""}
_SEEN_MAX = 4096


def _all_ids(names, seen: set = _IDS_SEEN) -> bool:
    """Whether every name is an id (``seen`` = :data:`_LABELS_SEEN`: an id or ""); names are strings."""
    if seen.issuperset(names):
        return True
    for u in names:
        if u not in seen:
            if not is_id(u):
                return False
            if len(seen) >= _SEEN_MAX:
                seen.clear()
                seen.update(("",) if seen is _LABELS_SEEN else ())
            seen.add(u)
    return True


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

    SCHEMA: ClassVar[str] = "detections/4"
    MAX_BYTES: ClassVar[int] = 192 << 10   # 2000 blobs take ~132 kB, ~188 kB with velocities
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
    sigma_crowd_blob_frame_px: float | None = None  # of sigma_crowd_blob_px, the per-frame part (None: all; 0: left to the localizer)

    def _rules(self) -> None:   # on every frame: the reasons are only formatted for a refusal
        if len(self.blobs) > MAX_BLOBS:
            _rule(False, "blobs", f"at most {MAX_BLOBS} blobs in a frame, got {len(self.blobs)}")
        _rule(self.focal_px > 0, "focal_px", "expected a focal length > 0")
        f = self.sigma_crowd_blob_frame_px
        if f is not None:
            _rule(0.0 <= f <= self.sigma_crowd_blob_px, "sigma_crowd_blob_frame_px",
                  "expected 0 <= sigma_crowd_blob_frame_px <= sigma_crowd_blob_px")
        _rule(_all_ids(self.landmarks.ugv), "landmarks", "landmark names must be ids")
        _rule(_all_ids(self.blobs.ugv, _LABELS_SEEN), "blobs", "blob labels must be ids or empty")

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
    SCHEMA: ClassVar[str] = "crowd/2"
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
    unseen_s: float = 0.0                   # 0: seen in this frame; else seconds unseen, placed where its walk takes it

    def _rules(self) -> None:
        _rule(len(self.footprint_lat_deg) == len(self.footprint_lon_deg), "footprint_lon_deg",
              f"{len(self.footprint_lat_deg)} latitudes but {len(self.footprint_lon_deg)} longitudes")
        _rule(len(self.footprint_lat_deg) <= 64, "footprint_lat_deg", "at most 64 footprint corners")
        _rule(self.quality in QUALITIES, "quality", f"expected one of {', '.join(QUALITIES)}")


@dataclass(frozen=True, slots=True)
class Crowds:
    """Geolocated crowds of one UAV frame. Key: uvteam/<team>/<localizer>/crowds (the sender's own key)."""

    SCHEMA: ClassVar[str] = "crowds/3"
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
        _rule(_all_ids(self.landmarks_used + self.outlier_landmarks), "landmarks_used",
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


def _enc_hook(v: Any) -> Any:
    if isinstance(v, np.ndarray):
        return v.tolist()
    if isinstance(v, np.generic):
        return v.item()
    raise NotImplementedError(f"cannot put a {type(v).__name__} on the wire")


_ENCODER = msgspec.msgpack.Encoder(enc_hook=_enc_hook)


def encode(msg: Any) -> bytes:
    """Message -> bytes. Refuses to send what decode would refuse (never a NaN on the wire)."""
    try:
        # msgspec writes a dataclass as the map of its fields, as _to_wire does, in one pass in C
        raw = _ENCODER.encode({"schema": type(msg).SCHEMA, "data": msg})
    except (TypeError, NotImplementedError, msgspec.EncodeError):
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
    if name.endswith("_acc_m") or name.startswith("sigma_") or name in ("radius95_m", "distance_m", "alt_agl_m",
                                                                           "unseen_s"):
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
        if is_ident and not _all_ids((v,)):
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
    fast = _fast_decoder(cls)
    return _decode_checked(cls, raw) if fast is None else fast(raw)


def _decode_checked(cls: type[T], raw: bytes) -> T:
    """The reference decoder: every rule checked in Python, and a refusal explained."""
    return _from_wire(cls, _unpack_checked(cls, raw))


def _unpack_checked(cls: type, raw: bytes) -> Any:
    schema = cls.SCHEMA
    max_bytes, limits = _unpack_limits(cls)
    if len(raw) > max_bytes:
        raise MessageError(schema, "<payload>", f"payload of {len(raw)} bytes is over {schema}'s {max_bytes}")
    try:
        # arrays as tuples: an empty one is a shared singleton, so a payload of empty arrays costs little
        return msgpack.unpackb(raw, raw=False, strict_map_key=True, use_list=False, **limits)
    except Exception as exc:  # msgpack raises several unrelated types for bad input
        raise MessageError(schema, "<payload>", f"not MessagePack within limits: {exc}") from None


def _from_wire(cls: type[T], wire: Any) -> T:
    schema = cls.SCHEMA
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


# --- the fast decoder: msgspec structs generated from the dataclasses -------------------------------
class _Refused(Exception):
    """The fast decoder cannot accept a payload: the checked decoder decides."""


_FAST_REFUSALS = (_Refused, msgspec.MsgspecError, ValueError, TypeError, OverflowError)
_MAX_FLOAT = sys.float_info.max
_FINITE = msgspec.Meta(ge=-_MAX_FLOAT, le=_MAX_FLOAT)     # NaN and infinities fail both bounds
_SLOW_ONLY = frozenset({Frame})   # one big bytes field: the checked decoder costs one copy, like msgspec
_new = object.__new__
_set = object.__setattr__
_chain = itertools.chain.from_iterable
_fromiter = np.fromiter


def _float_meta(name: str) -> msgspec.Meta:
    """:func:`field_range`'s bounds for a float field, as msgspec constraints (NaN fails every bound);
    one table for both decoders and the published schemas."""
    r = field_range(name)
    if r is None:
        return _FINITE
    lo, hi, lo_closed, hi_closed, _ = r
    bounds = {"ge" if lo_closed else "gt": -_MAX_FLOAT if lo is None else lo,
              "le" if hi_closed else "lt": _MAX_FLOAT if hi is None else hi}
    return msgspec.Meta(**bounds)


def _refuse() -> None:
    raise _Refused


def _check_ids(v: str) -> str:
    return v if _all_ids((v,)) else _refuse()


def _vector(v: list) -> np.ndarray:
    return np.array(v, float) if v else np.empty(0)


def _rows(cols: int) -> Callable[[list], np.ndarray]:
    def conv(v: list) -> np.ndarray:
        return np.array(v, float) if v else np.empty((0, cols))
    return conv


class _FastGen:
    """msgspec types and converters for one message type; ``min_entry`` tracks the smallest map entry."""

    def __init__(self) -> None:
        self.min_entry = 1 << 30
        self.structs: dict[type, tuple[type, Callable]] = {}

    def field_type(self, name: str, tp: Any) -> tuple[Any, Callable | None]:
        """(msgspec type, converter to the dataclass's value or None) of one field, as :func:`_checker`."""
        origin = typing.get_origin(tp)
        if origin is Annotated:
            base, *meta = typing.get_args(tp)
            cols = next((m.n for m in meta if isinstance(m, Columns)), None)
            if base is np.ndarray and cols is not None:
                num = Annotated[float, _FINITE]
                row = num if cols == 0 else tuple.__class_getitem__((num,) * cols)
                return Annotated[list[row], msgspec.Meta(max_length=MAX_LIST)], (_vector if cols == 0 else _rows(cols))
            return self.field_type(name, base)
        if origin in (types.UnionType, typing.Union):
            args = [a for a in typing.get_args(tp) if a is not type(None)]
            inner, conv = self.field_type(name, args[0])
            return typing.Optional[inner], (None if conv is None else (lambda v: None if v is None else conv(v)))
        if tp is float:
            return Annotated[float, _float_meta(name)], None
        if tp is int:
            return Annotated[int, msgspec.Meta(ge=0, lt=1 << 53)], None
        if tp is str:
            return Annotated[str, msgspec.Meta(max_length=256)], (_check_ids if name in ID_FIELDS else None)
        if tp is bytes:
            return bytes, None
        if origin is tuple:
            inner, conv = self.field_type(name, typing.get_args(tp)[0])
            return (Annotated[tuple[inner, ...], msgspec.Meta(max_length=MAX_LIST)],
                    None if conv is None else (lambda v: tuple(map(conv, v))))
        if origin is dict:
            _k, v = typing.get_args(tp)
            inner, conv = self.field_type(name, v)
            self.min_entry = min(self.min_entry, 3)     # a one-character key and a one-byte value

            def mapping(d: dict) -> dict:
                if not _all_ids(d):
                    raise _Refused
                return d if conv is None else {k: conv(x) for k, x in d.items()}
            return Annotated[dict[str, inner], msgspec.Meta(max_length=256)], mapping
        if isinstance(tp, type) and is_dataclass(tp):
            return self.struct(tp)
        raise TypeError(f"{name}: unsupported field type {tp!r}")

    def struct(self, cls: type) -> tuple[type, Callable]:
        if cls in self.structs:
            return self.structs[cls]
        hints = typing.get_type_hints(cls, include_extras=True)
        specs, convs = [], []
        for i, f in enumerate(fields(cls)):
            ftype, conv = self.field_type(f.name, hints[f.name])
            self.min_entry = min(self.min_entry, len(msgpack.packb(f.name)) + 1)
            if f.default is not MISSING:
                specs.append((f.name, ftype, f.default))
            elif f.default_factory is not MISSING:
                specs.append((f.name, ftype, msgspec.field(default_factory=f.default_factory)))
            else:
                specs.append((f.name, ftype))
            if conv is not None:
                convs.append((i, conv))
        if cls is Blobs and specs[2][0] == "area_px":    # Blobs' own rule, checked as msgspec decodes
            area = Annotated[float, msgspec.Meta(ge=0.0, le=_MAX_FLOAT)]
            specs[2] = ("area_px", Annotated[list[area], msgspec.Meta(max_length=MAX_LIST)], *specs[2][2:])
        st = msgspec.defstruct(f"_Wire{cls.__name__}", specs, forbid_unknown_fields=True)
        build = _BUILDERS.get(cls, _build)(cls, convs)
        self.structs[cls] = (st, build)
        return st, build


def _build(cls: type, convs: list) -> Callable:
    """struct -> dataclass (fields converted, the type's own checks and ``_rules`` run), as one generated
    function per type: ``cls(c3(st.a), st.b, ...)``, as dataclasses generate their ``__init__``."""
    names = [f.name for f in fields(cls)]
    conv_of = dict(convs)
    env: dict[str, Any] = {"cls": cls, "rules": getattr(cls, "_rules", None)}
    args = []
    for i, n in enumerate(names):
        if i in conv_of:
            env[f"c{i}"] = conv_of[i]
            args.append(f"c{i}(st.{n})")
        else:
            args.append(f"st.{n}")
    src = (f"def build(st):\n    msg = cls({', '.join(args)})\n"
           + ("    rules(msg)\n" if env["rules"] is not None else "") + "    return msg\n")
    exec(src, env)   # noqa: S102 - the source is built from the dataclass's own field names
    return env["build"]


def _build_blobs(cls: type, convs: list) -> Callable:
    """Blobs without a second pass over its arrays: what ``Blobs.__post_init__`` checks, checked here on
    what msgspec already typed (rows of finite numbers), the rest (lengths, boxes, areas) in one go."""
    if [f.name for f in fields(cls)] != ["xy_px", "xyxy_px", "area_px", "ugv", "v_px_s", "sigma_v_px_s"]:
        return _build(cls, convs)      # Blobs changed: construct it the ordinary way

    def build(st: Any) -> Blobs:
        xy, box, area, ugv, v, sv = st.xy_px, st.xyxy_px, st.area_px, st.ugv, st.v_px_s, st.sigma_v_px_s
        n = len(xy)
        if len(box) != n or len(area) != n or (ugv and len(ugv) != n) or len(v) != len(sv) or len(v) not in (0, n):
            raise _Refused
        if n:   # msgspec typed the rows (two and four finite numbers each, areas >= 0): no shape to discover
            for x0, y0, x1, y1 in box:    # on the tuples: cheaper than numpy for tens of rows
                if x1 < x0 or y1 < y0:
                    raise _Refused
            a_xy = _fromiter(_chain(xy), float, 2 * n).reshape(n, 2)
            a_box = _fromiter(_chain(box), float, 4 * n).reshape(n, 4)
            a_area = np.array(area, float)
        else:
            a_xy, a_box, a_area = np.empty((0, 2)), np.empty((0, 4)), np.empty(0)
        b = _new(Blobs)
        _set(b, "xy_px", a_xy)
        _set(b, "xyxy_px", a_box)
        _set(b, "area_px", a_area)
        _set(b, "ugv", ugv if ugv else ("",) * n)
        if len(v):
            if min(sv) < 0:
                raise _Refused
            _set(b, "v_px_s", _fromiter(_chain(v), float, 2 * n).reshape(n, 2))
            _set(b, "sigma_v_px_s", np.array(sv, float))
        else:
            _set(b, "v_px_s", np.empty((0, 2)))
            _set(b, "sigma_v_px_s", np.empty(0))
        return b
    return build


def _build_landmarks(cls: type, convs: list) -> Callable:
    """Landmarks as :func:`_build_blobs` builds Blobs: names one per row, non-empty and unique."""
    if [f.name for f in fields(cls)] != ["ugv", "xy_px"]:
        return _build(cls, convs)

    def build(st: Any) -> Landmarks:
        ugv, xy = st.ugv, st.xy_px
        if len(ugv) != len(xy) or "" in ugv or len(set(ugv)) != len(ugv):
            raise _Refused
        lm = _new(Landmarks)
        _set(lm, "ugv", ugv)
        _set(lm, "xy_px", _fromiter(_chain(xy), float, 2 * len(xy)).reshape(-1, 2) if xy else np.empty((0, 2)))
        return lm
    return build


_BUILDERS = {Blobs: _build_blobs, Landmarks: _build_landmarks}


@cache
def _fast_decoder(cls: type) -> Callable[[bytes], Any] | None:
    """A decoder bytes -> ``cls`` (None: types left to the checked decoder) that hands what it does not
    accept to the checked one. The checked decoder's unpacking limits are kept: a payload too short to
    hold a map of more than 512 entries cannot break them; a longer one is unpacked with the limits first
    (msgspec takes a repeated key's last value, as msgpack does, but has no cap), and that unpacking is
    what the checked decoder goes on from, so a refused bomb costs what it did."""
    if cls in _SLOW_ONLY:
        return None
    gen = _FastGen()
    data_t, build = gen.struct(cls)
    env = msgspec.defstruct(f"_Envelope{cls.__name__}", [("schema", str), ("data", data_t)], forbid_unknown_fields=True)
    decoder = msgspec.msgpack.Decoder(env)
    schema = cls.SCHEMA
    unlimited_below = min(513 * gen.min_entry, _unpack_limits(cls)[0] + 1)

    def attempt(raw: bytes) -> Any:
        """The message if msgspec and the builders accept ``raw``, else one of ``_FAST_REFUSALS``."""
        env = decoder.decode(raw)
        if env.schema != schema:
            raise _Refused
        return build(env.data)

    def fast(raw: bytes) -> Any:
        wire = None
        if len(raw) >= unlimited_below:   # (or over MAX_BYTES): unpacked within limits first
            wire = _unpack_checked(cls, raw)
        try:
            return attempt(raw)
        except _FAST_REFUSALS:   # the checked decoder accepts it after all, or says what is wrong with it
            return _from_wire(cls, wire) if wire is not None else _decode_checked(cls, raw)
    fast.attempt = attempt   # for the tests that hold the two decoders to each other
    return fast
