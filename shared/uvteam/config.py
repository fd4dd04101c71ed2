"""Vehicle configuration: one TOML file per vehicle (deploy/vehicles/*.toml) -> frozen dataclasses.

Unknown or missing keys are errors naming the file and the key; defaults < file < command-line flags.

    [vehicle]   team, id, role ("uav" | "ugv" | "localizer")
    [bus]       zenoh_config, mode, connect, listen                      (all optional)
    [autopilot] url, system_id, component_id, signing_key_file, link_timeout_s
    [uav]       detector, colors (color -> UGV id), camera, ...         (role uav)
    [ugv]       uav, team_ugvs, station_radius_m, max_speed_m_s, ...     (role ugv)
    [localizer] uav, ugvs, origin_lat_deg, origin_lon_deg, gate_px, ...  (role localizer)
"""

from __future__ import annotations

from dataclasses import MISSING, dataclass, field, fields, replace
from pathlib import Path
from typing import Any

from .bus import BusConfig
from .errors import ConfigError
from .keys import check_id

__all__ = ["VehicleConfig", "AutopilotConfig", "UavConfig", "UgvConfig", "LocalizerServiceConfig"]


@dataclass(frozen=True)
class AutopilotConfig:
    url: str = ""                          # "" = no autopilot (e.g. the localizer)
    system_id: int = 1
    component_id: int = 0                  # 0 = any component of system_id
    signing_key_file: str = ""             # 32-byte key file for MAVLink 2 signing; "" = unsigned
    link_timeout_s: float = 3.0


@dataclass(frozen=True)
class UavConfig:
    detector: str = "sim-sensor"           # "sim-sensor" | "pixels"
    colors: dict = field(default_factory=dict)   # color name -> UGV id
    camera: str = "zenoh"                  # frames for "pixels": "zenoh" (the bus key .../frame), device:N, a file, rtsp://, gst:
    hfov_deg: float = 78.0                 # the camera's horizontal field of view (no distortion)
    label_side_m: float = 1.0              # side of the UGVs' square roof labels


@dataclass(frozen=True)
class UgvConfig:
    uav: str = "uav1"                      # whose crowds this UGV follows
    team_ugvs: tuple = ()                  # all UGV ids (the planner spreads them around the crowd)
    station_radius_m: float = 12.0
    max_speed_m_s: float = 4.0
    tracking_interval_s: float = 1.0
    horizon_s: float = 3.0
    view_half_width_m: float = 0.0         # 0 = unknown: the ring is not shrunk to the UAV's view
    view_half_height_m: float = 0.0
    camera: str = ""                       # forward camera for HOG people detection (device:N, file, rtsp://, gst:); "" = none
    camera_hfov_deg: float = 70.0          # used when no reference calibration is given
    camera_yaw_deg: float = 0.0            # camera axis relative to the vehicle's heading, clockwise
    camera_ref_distance_m: float = 0.0     # the paper's calibration f = D*h/H: a person of person_height_m at
    camera_ref_box_height_px: float = 0.0  #   this distance gives a detector box this tall (0 = use the hfov)
    person_height_m: float = 1.7
    people_rate_hz: float = 5.0            # HOG frames per second at most


@dataclass(frozen=True)
class LocalizerServiceConfig:
    uav: str = "uav1"
    ugvs: tuple = ()                       # UGV ids used as landmarks
    origin_lat_deg: float = float("nan")   # NaN = the first UGV fix
    origin_lon_deg: float = float("nan")
    gate_px: float = 25.0
    tracking_interval_s: float = 1.0
    image_coordinates: str = "motion"
    solver: str = "optimal"
    hold_max_s: float = 1.0
    sigma_landmark_px: float = 1.0
    sigma_target_px: float = 1.5
    confirm_hits: int = 3


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


def _section(cls, data: Any, src: str, name: str):
    if not isinstance(data, dict):
        raise ConfigError(src, name, "expected a table")
    known = {f.name: f for f in fields(cls)}
    kw = {}
    for k, v in data.items():
        if k not in known:
            raise ConfigError(src, f"{name}.{k}", f"unknown key (known: {', '.join(sorted(known))})")
        f = known[k]
        want = f.default if f.default is not MISSING else (f.default_factory() if f.default_factory is not MISSING else None)
        if isinstance(want, bool) or isinstance(want, str):
            if not isinstance(v, type(want)):
                raise ConfigError(src, f"{name}.{k}", f"expected {type(want).__name__}, got {v!r}")
        elif isinstance(want, float):
            if isinstance(v, bool) or not isinstance(v, (int, float)):
                raise ConfigError(src, f"{name}.{k}", f"expected a number, got {v!r}")
            v = float(v)
        elif isinstance(want, int):
            if isinstance(v, bool) or not isinstance(v, int):
                raise ConfigError(src, f"{name}.{k}", f"expected an integer, got {v!r}")
        elif isinstance(want, tuple):
            if not isinstance(v, list):
                raise ConfigError(src, f"{name}.{k}", f"expected a list, got {v!r}")
            v = tuple(v)
        elif isinstance(want, dict) and not isinstance(v, dict):
            raise ConfigError(src, f"{name}.{k}", f"expected a table, got {v!r}")
        kw[k] = v
    return cls(**kw)


def vehicle_config_from_dict(raw: dict, src: str, *, base_dir: Path | None = None,
                             bus_override: BusConfig | None = None) -> VehicleConfig:
    """A parsed vehicle TOML -> a checked VehicleConfig, or ConfigError naming ``src`` and the key.
    A relative ``bus.zenoh_config`` is taken relative to ``base_dir`` (the file's folder)."""
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
    try:
        check_id("vehicle.team", v["team"])
        check_id("vehicle.id", v["id"])
    except ConfigError as exc:
        raise ConfigError(src, exc.key, exc.reason) from None
    if v["role"] not in ("uav", "ugv", "localizer"):
        raise ConfigError(src, "vehicle.role", f"must be uav, ugv or localizer, got {v['role']!r}")
    b = raw.get("bus", {})
    bus = BusConfig()
    if b:
        for k in b:
            if k not in ("zenoh_config", "mode", "connect", "listen"):
                raise ConfigError(src, f"bus.{k}", "unknown key")
        zc = b.get("zenoh_config") or None
        if zc and base_dir is not None and not Path(zc).is_absolute():
            zc = str((base_dir / zc).resolve())
        bus = BusConfig(config_file=zc, mode=b.get("mode"), connect=tuple(b.get("connect", ())),
                        listen=tuple(b.get("listen", ())))
    if bus_override is not None:
        bus = replace(bus, **{k: getattr(bus_override, k) for k in ("config_file", "mode")
                               if getattr(bus_override, k)},
                      **{k: getattr(bus_override, k) for k in ("connect", "listen") if getattr(bus_override, k)})
    cfg = VehicleConfig(
        team=v["team"], id=v["id"], role=v["role"], bus=bus,
        autopilot=_section(AutopilotConfig, raw.get("autopilot", {}), src, "autopilot"),
        uav=_section(UavConfig, raw.get("uav", {}), src, "uav"),
        ugv=_section(UgvConfig, raw.get("ugv", {}), src, "ugv"),
        localizer=_section(LocalizerServiceConfig, raw.get("localizer", {}), src, "localizer"),
        source=src)
    if cfg.role in ("uav", "ugv") and not cfg.autopilot.url:
        raise ConfigError(src, "autopilot.url", f"a {cfg.role} needs its autopilot link")
    for color, ugv in cfg.uav.colors.items():
        check_id(f"uav.colors.{color}", ugv)
    if cfg.localizer.image_coordinates not in ("motion", "color"):
        raise ConfigError(src, "localizer.image_coordinates", "must be motion or color")
    return cfg


__all__ += ["vehicle_config_from_dict"]
