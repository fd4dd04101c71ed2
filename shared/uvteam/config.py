"""Vehicle configuration: one TOML file per vehicle (deploy/vehicles/*.toml) -> frozen dataclasses. Pure:
:func:`vehicle_config_from_dict` takes the parsed file (reading it is :func:`uvteam.io.files.load_vehicle_config`).

Unknown, missing or mistyped keys, values out of range (every number has one), unknown words (roles,
detectors, colors, ...: :mod:`uvteam.vocab`) and ids that are not ids are errors naming the file and
the key, raised at start-up (exit code 2) before anything else runs. Defaults < file < command-line flags.

    [vehicle]   team, id, role ("uav" | "ugv" | "localizer")
    [bus]       zenoh_config, mode, connect, listen                      (all optional)
    [autopilot] url, system_id, component_id, signing_key_file, link_timeout_s
    [uav]       detector, colors (color -> UGV id), camera, ...         (role uav)
    [ugv]       uav, localizer, team_ugvs, station_radius_m, ...         (role ugv)
    [localizer] uav, ugvs, origin_lat_deg, origin_lon_deg, gate_px, ...  (role localizer)

The defaults are the tuning a deployed team runs with; the shipped files in deploy/vehicles/ set only
what is particular to a vehicle (ids, endpoints, the autopilot link, colors), and so do the demo and
the experiment (:mod:`uvteam.team`), so their figures are what a deployed user gets. When to override
a default is said beside it.
"""

from __future__ import annotations

import math
import re
import types
import typing
from dataclasses import MISSING, dataclass, field, fields, replace
from pathlib import Path
from typing import Any

from .bus import BusConfig
from .errors import ConfigError
from .vocab import COLORS, DETECTORS, GIMBALS, IMAGE_COORDINATES, ROLES, SOLVERS, is_id

__all__ = ["VehicleConfig", "AutopilotConfig", "UavConfig", "UgvConfig", "LocalizerServiceConfig",
           "vehicle_config_from_dict", "vehicle_config_to_toml"]


def _num(lo: float | None = None, hi: float | None = None, *, lo_open: bool = False, finite: bool = True) -> dict:
    return {"range": (lo, hi, lo_open, finite)}


def _choice(choices: tuple) -> dict:
    return {"choices": choices}


_HOSTPORT = re.compile(r"\[?([^\[\]\s]+?)\]?:(\d{1,5})")
VIDEO_SUFFIXES = (".mp4", ".avi")
ID = {"id": True}
IDS = {"ids": True}
POSITIVE = _num(0.0, None, lo_open=True)
NON_NEGATIVE = _num(0.0, None)


@dataclass(frozen=True)
class AutopilotConfig:
    url: str = ""                          # "" = no autopilot (e.g. the localizer)
    system_id: int = field(default=1, metadata=_num(1, 255))
    component_id: int = field(default=0, metadata=_num(0, 255))       # 0 = any component of system_id
    signing_key_file: str = ""             # 32-byte key file for MAVLink 2 signing; "" = unsigned
    link_timeout_s: float = field(default=3.0, metadata=POSITIVE)


@dataclass(frozen=True)
class UavConfig:
    detector: str = field(default="sim-sensor", metadata=_choice(DETECTORS))
    colors: dict = field(default_factory=dict, metadata={"color_map": True})   # roof color -> UGV id
    camera: str = "zenoh"                  # frames for "pixels": "zenoh" (the bus key .../frame), device:N, a file, rtsp://, gst:
    hfov_deg: float = field(default=78.0, metadata=_num(1.0, 179.0))  # the camera's horizontal field of view (no distortion)
    label_side_m: float = field(default=1.0, metadata=POSITIVE)       # side of the UGVs' square roof labels
    # The camera's mounting and what its pose is worth (the pose predicts where each UGV's label must be,
    # is the localizer's prior, and places crowds when fewer than four landmarks are seen):
    gimbal: str = field(default="stabilised", metadata=_choice(GIMBALS))  # stabilised: looks down whatever the body does
    mount_roll_deg: float = field(default=0.0, metadata=_num(-90.0, 90.0))   # the camera's tilt from straight down
    mount_pitch_deg: float = field(default=0.0, metadata=_num(-90.0, 90.0))  #   (the gimbal's, or the fixed mount's)
    mount_yaw_deg: float = field(default=0.0, metadata=_num(-360.0, 360.0))  # the image top from the heading, clockwise
    attitude_sigma_deg: float = field(default=1.0, metadata=POSITIVE)   # 1-sigma of the camera's roll and pitch
    heading_sigma_deg: float = field(default=3.0, metadata=POSITIVE)    # ... of its yaw (compass)
    alt_sigma_m: float = field(default=1.0, metadata=POSITIVE)          # ... of its height above ground
    position_sigma_m: float = field(default=0.0, metadata=NON_NEGATIVE)  # ... of its position; 0: the autopilot's accuracy
    # what the UAV sees, drawn (uvteam.vision.annotate: blobs, landmarks, the localizer's crowds), "pixels" only:
    annotate_http: str = field(default="", metadata={"hostport": True})       # MJPEG over HTTP on HOST:PORT ("" = off;
    #                                                                            e.g. 127.0.0.1:8771; a public address shows it to all)
    annotate_video: str = field(default="", metadata={"video_file": True})    # also write it to this .mp4 or .avi ("" = off)


@dataclass(frozen=True)
class UgvConfig:
    uav: str = field(default="uav1", metadata=ID)              # whose fix the team stays around when no crowd is known
    localizer: str = field(default="loc1", metadata=ID)        # whose crowds this UGV follows (and only whose)
    team_ugvs: tuple = field(default=(), metadata=IDS)         # all UGV ids (the planner spreads them around the crowd)
    station_radius_m: float = field(default=12.0, metadata=POSITIVE)
    max_speed_m_s: float = field(default=4.0, metadata=POSITIVE)
    tracking_interval_s: float = field(default=1.0, metadata=POSITIVE)
    horizon_s: float = field(default=3.0, metadata=POSITIVE)
    view_half_width_m: float = field(default=0.0, metadata=NON_NEGATIVE)   # 0 = unknown: the ring is not shrunk to the UAV's view
    view_half_height_m: float = field(default=0.0, metadata=NON_NEGATIVE)
    crowd_stale_s: float = field(default=5.0, metadata=POSITIVE)           # an older crowd estimate is not planned around
    fix_stale_s: float = field(default=3.0, metadata=POSITIVE)             # an older teammate fix is not planned with
    max_h_acc_m: float = field(default=10.0, metadata=POSITIVE)            # a worse fix of its own is not published
    camera: str = ""                       # forward camera for HOG people detection (device:N, file, rtsp://, gst:); "" = none
    camera_hfov_deg: float = field(default=70.0, metadata=_num(1.0, 179.0))  # used when no reference calibration is given
    camera_yaw_deg: float = field(default=0.0, metadata=_num(-360.0, 360.0))  # camera axis relative to the heading, clockwise
    camera_ref_distance_m: float = field(default=0.0, metadata=NON_NEGATIVE)  # the paper's calibration f = D*h/H: a person of
    camera_ref_box_height_px: float = field(default=0.0, metadata=NON_NEGATIVE)  # person_height_m at D gives a box this tall (0 = hfov)
    person_height_m: float = field(default=1.7, metadata=_num(0.5, 2.5))
    people_rate_hz: float = field(default=5.0, metadata=NON_NEGATIVE)     # HOG frames per second at most (0 = every frame)


@dataclass(frozen=True)
class LocalizerServiceConfig:
    uav: str = field(default="uav1", metadata=ID)
    ugvs: tuple = field(default=(), metadata=IDS)          # UGV ids used as landmarks (empty: every vehicle but the UAV)
    origin_lat_deg: float = field(default=math.nan, metadata=_num(-90.0, 90.0, finite=False))   # NaN = the first UGV fix
    origin_lon_deg: float = field(default=math.nan, metadata=_num(-180.0, 180.0, finite=False))
    gate_px: float = field(default=25.0, metadata=POSITIVE)               # the paper's epsilon
    tracking_interval_s: float = field(default=1.0, metadata=POSITIVE)
    image_coordinates: str = field(default="motion", metadata=_choice(IMAGE_COORDINATES))
    solver: str = field(default="optimal", metadata=_choice(SOLVERS))
    hold_max_s: float = field(default=1.0, metadata=POSITIVE)
    # The pixel noise the 95 % radius propagates. Leave unset: the detector declares it with every frame
    # (uvteam.detector_noise, scaled to its camera and altitude). Set only for a detector that declares
    # none or one you have measured to be off.
    sigma_landmark_px: float = field(default=math.nan, metadata=_num(0.0, None, finite=False))
    sigma_target_px: float = field(default=math.nan, metadata=_num(0.0, None, finite=False))
    confirm_hits: int = field(default=3, metadata=_num(1, 100))
    max_fix_skew_s: float = field(default=1.0, metadata=POSITIVE)     # a fix stamped further in the future is refused
    max_fix_age_s: float = field(default=30.0, metadata=POSITIVE)     # ... and one older than this on arrival
    max_h_acc_m: float = field(default=10.0, metadata=POSITIVE)       # ... and one less accurate than this
    max_blobs: int = field(default=64, metadata=_num(1, 2000))        # blobs per frame looked at (the largest):
    # six UGVs, a few crowds and their parts fit many times over; what a frame costs stays bounded


@dataclass(frozen=True)
class VehicleConfig:
    team: str
    id: str
    role: str
    bus: BusConfig = BusConfig()
    autopilot: AutopilotConfig = AutopilotConfig()
    uav: UavConfig = UavConfig()
    ugv: UgvConfig = UgvConfig()
    localizer: LocalizerServiceConfig = LocalizerServiceConfig()
    source: str = ""


def _base_type(tp: Any) -> Any:
    if typing.get_origin(tp) in (types.UnionType, typing.Union):
        return next(a for a in typing.get_args(tp) if a is not type(None))
    return tp


def _check_field(src: str, key: str, f, v: Any) -> Any:
    """One value against its field's type and declared checks; the checked value or ConfigError."""
    def bad(why: str) -> ConfigError:
        return ConfigError(src, key, why)

    default = f.default if f.default is not MISSING else f.default_factory()
    meta = f.metadata
    if isinstance(default, bool):
        if not isinstance(v, bool):
            raise bad(f"expected true or false, got {v!r}")
    elif isinstance(default, str):
        if not isinstance(v, str):
            raise bad(f"expected a string, got {v!r}")
    elif isinstance(default, float):
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise bad(f"expected a number, got {v!r}")
        v = float(v)
    elif isinstance(default, int):
        if isinstance(v, bool) or not isinstance(v, int):
            raise bad(f"expected an integer, got {v!r}")
    elif isinstance(default, tuple):
        if not isinstance(v, list):
            raise bad(f"expected a list, got {v!r}")
        v = tuple(v)
    elif isinstance(default, dict):
        if not isinstance(v, dict):
            raise bad(f"expected a table, got {v!r}")
    if "range" in meta:
        lo, hi, lo_open, finite = meta["range"]
        if math.isnan(v):
            if finite:
                raise bad("expected a finite number, got nan")
        elif finite and not math.isfinite(v):
            raise bad(f"expected a finite number, got {v!r}")
        elif (lo is not None and (v < lo or (lo_open and v == lo))) or (hi is not None and v > hi):
            lo_s = "-inf" if lo is None else f"{lo:g}"
            hi_s = "inf" if hi is None else f"{hi:g}"
            raise bad(f"expected a value in {'(' if lo_open else '['}{lo_s}, {hi_s}], got {v!r}")
    if "choices" in meta and v not in meta["choices"]:
        raise bad(f"expected one of {', '.join(meta['choices'])}, got {v!r}")
    if meta.get("id") and not is_id(v):
        raise bad(f"expected an id (1-32 of A-Z a-z 0-9 _ -), got {v!r}")
    if meta.get("ids"):
        bad_ids = [x for x in v if not is_id(x)]
        if bad_ids:
            raise bad(f"expected ids (1-32 of A-Z a-z 0-9 _ -), got {bad_ids[0]!r}")
        if len(set(v)) != len(v):
            raise bad("ids must not repeat")
    if meta.get("hostport") and v:
        m = _HOSTPORT.fullmatch(v)
        if not m or not 0 < int(m.group(2)) <= 65535:
            raise bad(f"expected HOST:PORT (e.g. 127.0.0.1:8771, [::1]:8771), got {v!r}")
    if meta.get("video_file") and v and Path(v).suffix.lower() not in VIDEO_SUFFIXES:
        raise bad(f"expected a {' or '.join(VIDEO_SUFFIXES)} file, got {v!r}")
    if meta.get("color_map"):
        for color, ugv in v.items():
            if color not in COLORS:
                raise ConfigError(src, f"{key}.{color}", f"unknown color; known: {', '.join(COLORS)}")
            if not is_id(ugv):
                raise ConfigError(src, f"{key}.{color}", f"expected a UGV id, got {ugv!r}")
        if len(set(v.values())) != len(v):
            raise bad("two colors name the same UGV")
    return v


def _section(cls, data: Any, src: str, name: str):
    if not isinstance(data, dict):
        raise ConfigError(src, name, "expected a table")
    known = {f.name: f for f in fields(cls)}
    kw = {}
    for k, v in data.items():
        if k not in known:
            raise ConfigError(src, f"{name}.{k}", f"unknown key (known: {', '.join(sorted(known))})")
        kw[k] = _check_field(src, f"{name}.{k}", known[k], v)
    return cls(**kw)


def vehicle_config_from_dict(raw: dict, src: str, *, base_dir: Path | None = None,
                             bus_override: BusConfig | None = None) -> VehicleConfig:
    """A parsed vehicle TOML -> a checked VehicleConfig, or ConfigError naming ``src`` and the key.
    A relative ``bus.zenoh_config`` is taken relative to ``base_dir`` (the file's folder)."""
    if not isinstance(raw, dict):
        raise ConfigError(src, "<file>", "expected a TOML table")
    allowed = {"vehicle", "bus", "autopilot", "uav", "ugv", "localizer"}
    for k in raw:
        if k not in allowed:
            raise ConfigError(src, k, f"unknown section (known: {', '.join(sorted(allowed))})")
    v = raw.get("vehicle")
    if not isinstance(v, dict):
        raise ConfigError(src, "vehicle", "missing")
    for k in ("team", "id", "role"):
        if k not in v:
            raise ConfigError(src, f"vehicle.{k}", "missing")
    for k in v:
        if k not in ("team", "id", "role"):
            raise ConfigError(src, f"vehicle.{k}", "unknown key")
    for k in ("team", "id"):
        if not is_id(v[k]):
            raise ConfigError(src, f"vehicle.{k}", f"must be 1-32 characters of A-Z a-z 0-9 _ -, got {v[k]!r}")
    if v["role"] not in ROLES:
        raise ConfigError(src, "vehicle.role", f"must be one of {', '.join(ROLES)}, got {v['role']!r}")
    bus = _bus_section(raw.get("bus", {}), src, base_dir)
    if bus_override is not None:
        bus = replace(bus, **{k: getattr(bus_override, k) for k in ("config_file", "mode")
                               if getattr(bus_override, k)},
                      **{k: getattr(bus_override, k) for k in ("connect", "listen", "cfg") if getattr(bus_override, k)})
    cfg = VehicleConfig(
        team=v["team"], id=v["id"], role=v["role"], bus=bus,
        autopilot=_section(AutopilotConfig, raw.get("autopilot", {}), src, "autopilot"),
        uav=_section(UavConfig, raw.get("uav", {}), src, "uav"),
        ugv=_section(UgvConfig, raw.get("ugv", {}), src, "ugv"),
        localizer=_section(LocalizerServiceConfig, raw.get("localizer", {}), src, "localizer"),
        source=src)
    if cfg.role in ("uav", "ugv") and not cfg.autopilot.url:
        raise ConfigError(src, "autopilot.url", f"a {cfg.role} needs its autopilot link")
    if cfg.role == "uav" and cfg.uav.detector == "pixels" and not cfg.uav.colors:
        raise ConfigError(src, "uav.colors", "the pixel detector needs the team's roof colors (color = UGV id)")
    return cfg


def _bus_section(b: Any, src: str, base_dir: Path | None) -> BusConfig:
    if not isinstance(b, dict):
        raise ConfigError(src, "bus", "expected a table")
    for k, val in b.items():
        if k not in ("zenoh_config", "mode", "connect", "listen"):
            raise ConfigError(src, f"bus.{k}", "unknown key")
        if k in ("connect", "listen") and not (isinstance(val, list) and all(isinstance(x, str) for x in val)):
            raise ConfigError(src, f"bus.{k}", f"expected a list of endpoints, got {val!r}")
        if k in ("zenoh_config", "mode") and not isinstance(val, str):
            raise ConfigError(src, f"bus.{k}", f"expected a string, got {val!r}")
    if b.get("mode") not in (None, "peer", "client", "router"):
        raise ConfigError(src, "bus.mode", f"must be peer, client or router, got {b['mode']!r}")
    zc = b.get("zenoh_config") or None
    if zc and base_dir is not None and not Path(zc).is_absolute():
        zc = str((base_dir / zc).resolve())
    return BusConfig(config_file=zc, mode=b.get("mode"), connect=tuple(b.get("connect", ())),
                     listen=tuple(b.get("listen", ())))


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return "nan" if math.isnan(v) else repr(v)
    if isinstance(v, int):
        return str(v)
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, (tuple, list)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{k} = {_toml_value(x)}" for k, x in v.items()) + " }"
    raise TypeError(f"no TOML for {v!r}")


def vehicle_config_to_toml(cfg: VehicleConfig, header: str = "") -> str:
    """A config as the TOML file that loads back to it; only values that differ from the defaults are
    written (the rest is the shipped tuning)."""
    out = [f"# {line}" for line in header.splitlines()]
    out += ["[vehicle]", f"team = {_toml_value(cfg.team)}", f"id = {_toml_value(cfg.id)}", f"role = {_toml_value(cfg.role)}"]
    bus = {k: getattr(cfg.bus, k) for k in ("mode", "connect", "listen") if getattr(cfg.bus, k)}
    if cfg.bus.config_file:
        bus["zenoh_config"] = cfg.bus.config_file
    if bus:
        out += ["", "[bus]"] + [f"{k} = {_toml_value(v)}" for k, v in bus.items()]
    sections = {"autopilot": cfg.autopilot, "uav": cfg.uav, "ugv": cfg.ugv, "localizer": cfg.localizer}
    for name, sec in sections.items():
        rows = []
        for f in fields(sec):
            default = f.default if f.default is not MISSING else f.default_factory()
            val = getattr(sec, f.name)
            same = (isinstance(val, float) and isinstance(default, float) and math.isnan(val) and math.isnan(default)) \
                or val == default
            if not same:
                rows.append(f"{f.name} = {_toml_value(val)}")
        if rows:
            out += ["", f"[{name}]"] + rows
    return "\n".join(out) + "\n"
