"""Scenario files (../shared/scenarios/*.toml): loaded into frozen dataclasses; every field is honoured.

Unknown or missing keys are errors naming the file and key, so a scenario cannot silently be
half-read. Format: ../shared/scenarios/README.md.
"""

from __future__ import annotations

import math
from dataclasses import MISSING, dataclass, fields

from uvteam.errors import ConfigError

__all__ = ["Scenario", "scenario_from_dict"]


@dataclass(frozen=True)
class World:
    origin_lat_deg: float
    origin_lon_deg: float
    ground_amsl_m: float
    terrain_relief_m: float
    terrain_wavelength_m: float


@dataclass(frozen=True)
class Run:
    duration_s: float
    frame_rate_hz: float
    seeds: tuple[int, ...]


@dataclass(frozen=True)
class Uav:
    altitude_agl_m: float
    follow: str
    follow_time_constant_s: float
    hover_wobble_m: float
    gimbal_jitter_deg: float
    # The errors of what the UAV's autopilot reports of its pose (optional; 0 = exact, as in the paper's
    # simulation and in files written before these fields):
    position_sigma_m: float = 0.0      # GNSS, per axis: a bias for the run plus a fifth of it per frame
    heading_sigma_deg: float = 0.0     # compass: a bias for the run
    alt_sigma_m: float = 0.0           # height above ground: a bias for the run


@dataclass(frozen=True)
class Camera:
    width_px: int
    height_px: int
    hfov_deg: float
    noise_sigma: float
    jpeg_quality: int


@dataclass(frozen=True)
class Ugvs:
    count: int
    colors: tuple[str, ...]
    length_m: float
    width_m: float
    label_side_m: float
    approach_speed_m_s: float
    station_speed_m_s: float
    station_radius_m: float
    initial_distance_m: tuple[float, float]


@dataclass(frozen=True)
class Gnss:
    sigma_m: float
    bias_walk_m_per_sqrt_s: float
    fix_rate_hz: float
    latency_s: float
    dropouts: tuple[tuple[int, float, float], ...]


@dataclass(frozen=True)
class CrowdSpec:
    members: int
    spread_m: float
    start_east_m: float
    start_north_m: float
    velocity_east_m_s: float
    velocity_north_m_s: float
    speed_range_m_s: tuple[float, ...]


@dataclass(frozen=True)
class Landmarks:
    image_coordinates: str


@dataclass(frozen=True)
class Events:
    lose_ugv: tuple[tuple[int, float], ...]


@dataclass(frozen=True)
class Scenario:
    name: str
    paper_mean_error_m: float
    world: World
    run: Run
    uav: Uav
    camera: Camera
    ugvs: Ugvs
    gnss: Gnss
    crowds: tuple[CrowdSpec, ...]
    landmarks: Landmarks
    events: Events
    path: str = ""


def _tuplify(v):
    return tuple(_tuplify(x) for x in v) if isinstance(v, list) else v


def _section(cls, data, src: str, where: str):
    if not isinstance(data, dict):
        raise ConfigError(src, where, "expected a table")
    names = {f.name for f in fields(cls)}
    for k in data:
        if k not in names:
            raise ConfigError(src, f"{where}.{k}", "unknown key")
    kw = {}
    for f in fields(cls):
        if f.name not in data:
            if f.default is not MISSING:
                continue
            raise ConfigError(src, f"{where}.{f.name}", "missing")
        v = _tuplify(data[f.name])
        if f.type in ("float",) and not isinstance(v, (int, float)):
            raise ConfigError(src, f"{where}.{f.name}", f"expected a number, got {v!r}")
        if f.type == "float":
            v = float(v)
        if f.type == "int" and (not isinstance(v, int) or isinstance(v, bool)):
            raise ConfigError(src, f"{where}.{f.name}", f"expected an integer, got {v!r}")
        kw[f.name] = v
    return cls(**kw)


def scenario_from_dict(raw: dict, src: str) -> Scenario:
    """A parsed scenario TOML -> a checked Scenario, or ConfigError naming ``src`` and the key."""
    top = {"name", "paper_mean_error_m", "world", "run", "uav", "camera", "ugvs", "gnss", "crowds", "landmarks", "events"}
    for k in raw:
        if k not in top:
            raise ConfigError(src, k, "unknown key")
    for k in top:
        if k not in raw:
            raise ConfigError(src, k, "missing")
    sc = Scenario(
        name=str(raw["name"]), paper_mean_error_m=float(raw["paper_mean_error_m"]),
        world=_section(World, raw["world"], src, "world"), run=_section(Run, raw["run"], src, "run"),
        uav=_section(Uav, raw["uav"], src, "uav"), camera=_section(Camera, raw["camera"], src, "camera"),
        ugvs=_section(Ugvs, raw["ugvs"], src, "ugvs"), gnss=_section(Gnss, raw["gnss"], src, "gnss"),
        crowds=tuple(_section(CrowdSpec, c, src, f"crowds[{i}]") for i, c in enumerate(raw["crowds"])),
        landmarks=_section(Landmarks, raw["landmarks"], src, "landmarks"),
        events=_section(Events, raw["events"], src, "events"), path=src)
    _validate(sc, src)
    return sc


def _validate(sc: Scenario, src: str) -> None:
    def need(cond: bool, key: str, why: str) -> None:
        if not cond:
            raise ConfigError(src, key, why)

    need(sc.ugvs.count == len(sc.ugvs.colors), "ugvs.colors", f"needs {sc.ugvs.count} colors")
    need(sc.ugvs.count >= 1, "ugvs.count", "at least one UGV")
    need(sc.uav.follow in ("crowd-lagged", "crowd", "fixed"), "uav.follow", "crowd-lagged, crowd or fixed")
    need(sc.landmarks.image_coordinates in ("motion", "color"), "landmarks.image_coordinates", "motion or color")
    need(sc.run.frame_rate_hz > 0 and sc.run.duration_s > 0 and len(sc.run.seeds) > 0, "run", "positive rate, duration, seeds")
    need(len(sc.ugvs.initial_distance_m) == 2, "ugvs.initial_distance_m", "[lo, hi]")
    need(sc.gnss.fix_rate_hz > 0, "gnss.fix_rate_hz", "> 0")
    need(len(sc.crowds) >= 1, "crowds", "at least one crowd")
    for i, c in enumerate(sc.crowds):
        need(len(c.speed_range_m_s) in (0, 2), f"crowds[{i}].speed_range_m_s", "[] or [lo, hi]")
        need(c.members >= 1, f"crowds[{i}].members", ">= 1")
    for d in sc.gnss.dropouts:
        need(len(d) == 3 and 0 <= int(d[0]) < sc.ugvs.count, "gnss.dropouts", "[[ugv_index, start_s, end_s]]")
    for e in sc.events.lose_ugv:
        need(len(e) == 2 and 0 <= int(e[0]) < sc.ugvs.count, "events.lose_ugv", "[[ugv_index, at_s]]")
    need(0 <= sc.camera.jpeg_quality <= 100, "camera.jpeg_quality", "0-100")
    for k in ("position_sigma_m", "heading_sigma_deg", "alt_sigma_m"):
        v = getattr(sc.uav, k)
        need(math.isfinite(v) and v >= 0, f"uav.{k}", ">= 0")
    need(math.isnan(sc.paper_mean_error_m) or sc.paper_mean_error_m > 0, "paper_mean_error_m", "> 0 or nan")
