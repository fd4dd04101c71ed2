"""Scenario files (../shared/scenarios/*.toml): loaded into frozen dataclasses; every field is honoured.

Unknown or missing keys are errors naming the file and key, so a scenario cannot silently be
half-read. Format: ../shared/scenarios/README.md (the fixed benchmark set).

Optional parts (``scenarios/README.md`` in the repository): the sections ``[ground]`` (procedural or
real-imagery ground texture), ``[distractors]`` (static label-coloured markings, parked vehicles and
roof patches) and ``[lens]`` (ground-texture prefilter and optical blur), the ``[uav]`` fields
``tilt_roll_deg``/``tilt_pitch_deg`` (a fixed gimbal tilt), and the ``[[crowds]]`` field
``turn_sigma_deg_s`` (a crowd that winds instead of walking straight). Each has a default that
reproduces the fixed set's worlds exactly, so a file without them means what it meant before they
existed. Only fields declared with a default may be left out; every other key is still required.
"""

from __future__ import annotations

import math
from dataclasses import MISSING, dataclass, field, fields

from uvteam.errors import ConfigError
from uvteam.vocab import COLORS

__all__ = ["Scenario", "scenario_from_dict", "Ground", "ImagerySource", "Distractors", "Lens",
           "GROUND_TEXTURES", "DISTRACTOR_KINDS", "PREFILTERS", "OBJECT_FILLS", "MAX_TILT_DEG", "off_nadir_deg"]

GROUND_TEXTURES = ("procedural", "imagery")
DISTRACTOR_KINDS = ("marking", "vehicle", "roof")
PREFILTERS = ("auto", "mipmap", "none")
OBJECT_FILLS = ("area", "opencv")
MAX_TILT_DEG = 10.0                  # off-nadir angle of the fixed gimbal tilt (the range tested)
MAX_ATTITUDE_SIGMA_DEG = 3.0         # the gimbal's unreported residual tilt, 1-sigma per axis
MAX_TURN_SIGMA_DEG_S = 30.0          # a crowd's turn rate, 1-sigma (people round a corner at 20-40 deg/s)
IMAGERY_GSD_RANGE_M = (0.002, 0.5)   # metres per pixel of real aerial imagery
TEXEL_RANGE_M = (0.005, 1.0)
TILE_RANGE_M = (2.0, 100.0)
MAX_DISTRACTORS = 1000
MAX_BLUR_SIGMA_PX = 10.0


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
    tilt_roll_deg: float = 0.0        # fixed gimbal roll (about the image x axis), beyond the per-frame jitter
    tilt_pitch_deg: float = 0.0       # fixed gimbal pitch (about the image y axis)
    # The errors of what the UAV's autopilot reports of its pose (optional; 0 = exact, as in the paper's
    # simulation and in files written before these fields):
    position_sigma_m: float = 0.0      # GNSS, per axis: a bias for the run plus a fifth of it per frame
    heading_sigma_deg: float = 0.0     # compass: a bias for the run
    alt_sigma_m: float = 0.0           # height above ground: a bias for the run
    attitude_sigma_deg: float = 0.0    # the gimbal's residual tilt, per axis: a bias for the run, not reported


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
    roof_labels: bool = True          # false: the UGVs carry no roof label (no landmarks: the pose places crowds)


@dataclass(frozen=True)
class Gnss:
    sigma_m: float
    bias_walk_m_per_sqrt_s: float
    fix_rate_hz: float
    latency_s: float
    dropouts: tuple[tuple[int, float, float], ...]
    bias_sigma_m: float = 0.0       # a bias per UGV and axis that drifts (Gauss-Markov): this 1-sigma, steady
    bias_time_s: float = 120.0      # ... and this correlation time (a receiver's error: slow, not white)


@dataclass(frozen=True)
class CrowdSpec:
    members: int
    spread_m: float
    start_east_m: float
    start_north_m: float
    velocity_east_m_s: float
    velocity_north_m_s: float
    speed_range_m_s: tuple[float, ...]
    turn_sigma_deg_s: float = 0.0     # 1-sigma of the crowd's turn rate (Ornstein-Uhlenbeck): a winding walk


@dataclass(frozen=True)
class Landmarks:
    image_coordinates: str


@dataclass(frozen=True)
class Events:
    lose_ugv: tuple[tuple[int, float], ...]


@dataclass(frozen=True)
class ImagerySource:
    """Real aerial frames for the ground: ``path`` is a file, a folder (its .jpg/.jpeg/.png files) or a
    glob pattern, relative to the scenario file's folder; ``gsd_m`` is their ground size of a pixel."""

    path: str
    gsd_m: float


@dataclass(frozen=True)
class Ground:
    texture: str = "procedural"       # "procedural" (the desert of render.py) | "imagery" (a mosaic of real frames)
    texel_m: float = 0.0              # metres per ground-texture texel; 0 = the nadir pixel footprint
    tile_m: float = 10.0              # imagery: side of the square pieces the mosaic is made of
    imagery: tuple[ImagerySource, ...] = ()


@dataclass(frozen=True)
class Distractors:
    """Static things in the UGVs' label colours at label size: seeded per run, none by default."""

    on_route: int = 0                 # on the UGVs' station ring around the first crowd's path
    near_crowd: int = 0               # within ``near_crowd_m`` of a crowd's path
    scattered: int = 0                # anywhere the camera sees during the run
    near_crowd_m: float = 8.0
    kinds: tuple[str, ...] = DISTRACTOR_KINDS
    colors: tuple[str, ...] = ()      # () = the UGVs' label colours

    @property
    def total(self) -> int:
        """How many distractors a run places (0: none)."""
        return self.on_route + self.near_crowd + self.scattered


@dataclass(frozen=True)
class Lens:
    prefilter: str = "auto"           # ground texture to the pixel footprint: "mipmap" | "none" | "auto"
    blur_sigma_px: float = 0.0        # Gaussian optical blur of the whole image, pixels
    objects: str = "area"             # objects' edge pixels: "area" (their covered share) | "opencv"

    @property
    def area_fill(self) -> bool:
        """Whether objects cover each pixel by its area's share, as a lens integrates light ("opencv":
        OpenCV's anti-aliased fill, whose edge pixels jump by up to 188 of 255 grey levels for a 1/32 px
        move, so still edges flicker under wobble; kept to reproduce the fixed set's frames as drawn until 2026-12-04)."""
        return self.objects == "area"

    def mipmap(self, ground: Ground) -> bool:
        """Whether the ground texture is area-averaged to each pixel's footprint ("auto": unless the
        ground is the default procedural one, whose texels already match the nadir pixel)."""
        if self.prefilter == "auto":
            return ground.texture != "procedural" or ground.texel_m > 0
        return self.prefilter == "mipmap"


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
    ground: Ground = field(default_factory=Ground)
    distractors: Distractors = field(default_factory=Distractors)
    lens: Lens = field(default_factory=Lens)


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
            if f.default is not MISSING or f.default_factory is not MISSING:
                continue   # an optional field: its default
            raise ConfigError(src, f"{where}.{f.name}", "missing")
        v = _tuplify(data[f.name])
        if f.type in ("float",) and not isinstance(v, (int, float)):
            raise ConfigError(src, f"{where}.{f.name}", f"expected a number, got {v!r}")
        if f.type == "float":
            v = float(v)
        if f.type == "int" and (not isinstance(v, int) or isinstance(v, bool)):
            raise ConfigError(src, f"{where}.{f.name}", f"expected an integer, got {v!r}")
        if f.type == "bool" and not isinstance(v, bool):
            raise ConfigError(src, f"{where}.{f.name}", f"expected true or false, got {v!r}")
        if f.type == "str" and not isinstance(v, str):
            raise ConfigError(src, f"{where}.{f.name}", f"expected a string, got {v!r}")
        if f.type == "tuple[str, ...]" and (not isinstance(v, tuple) or not all(isinstance(x, str) for x in v)):
            raise ConfigError(src, f"{where}.{f.name}", f"expected a list of strings, got {v!r}")
        kw[f.name] = v
    return cls(**kw)


def _ground(data, src: str) -> Ground:
    """``[ground]`` with its ``[[ground.imagery]]`` tables."""
    if not isinstance(data, dict):
        raise ConfigError(src, "ground", "expected a table")
    rest = {k: v for k, v in data.items() if k != "imagery"}
    sources = data.get("imagery", [])
    if not isinstance(sources, list):
        raise ConfigError(src, "ground.imagery", "expected [[ground.imagery]] tables (path, gsd_m)")
    imagery = tuple(_section(ImagerySource, d, src, f"ground.imagery[{i}]") for i, d in enumerate(sources))
    g = _section(Ground, rest, src, "ground")
    return Ground(g.texture, g.texel_m, g.tile_m, imagery)


def scenario_from_dict(raw: dict, src: str) -> Scenario:
    """A parsed scenario TOML -> a checked Scenario, or ConfigError naming ``src`` and the key."""
    top = {"name", "paper_mean_error_m", "world", "run", "uav", "camera", "ugvs", "gnss", "crowds", "landmarks", "events"}
    optional = {"ground", "distractors", "lens"}
    for k in raw:
        if k not in top | optional:
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
        events=_section(Events, raw["events"], src, "events"), path=src,
        ground=_ground(raw.get("ground", {}), src),
        distractors=_section(Distractors, raw.get("distractors", {}), src, "distractors"),
        lens=_section(Lens, raw.get("lens", {}), src, "lens"))
    _validate(sc, src)
    _validate_optional(sc, src)
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
    for k in ("sigma_m", "bias_walk_m_per_sqrt_s", "bias_sigma_m"):
        v = getattr(sc.gnss, k)
        need(math.isfinite(v) and v >= 0, f"gnss.{k}", ">= 0")
    need(sc.gnss.bias_time_s > 0, "gnss.bias_time_s", "> 0")
    need(len(sc.crowds) >= 1, "crowds", "at least one crowd")
    for i, c in enumerate(sc.crowds):
        need(len(c.speed_range_m_s) in (0, 2), f"crowds[{i}].speed_range_m_s", "[] or [lo, hi]")
        need(c.members >= 1, f"crowds[{i}].members", ">= 1")
        need(0.0 <= c.turn_sigma_deg_s <= MAX_TURN_SIGMA_DEG_S, f"crowds[{i}].turn_sigma_deg_s",
             f"0-{MAX_TURN_SIGMA_DEG_S:g} deg/s; got {c.turn_sigma_deg_s!r}")
    for d in sc.gnss.dropouts:
        need(len(d) == 3 and 0 <= int(d[0]) < sc.ugvs.count, "gnss.dropouts", "[[ugv_index, start_s, end_s]]")
    for e in sc.events.lose_ugv:
        need(len(e) == 2 and 0 <= int(e[0]) < sc.ugvs.count, "events.lose_ugv", "[[ugv_index, at_s]]")
    need(0 <= sc.camera.jpeg_quality <= 100, "camera.jpeg_quality", "0-100")
    for k in ("position_sigma_m", "heading_sigma_deg", "alt_sigma_m"):
        v = getattr(sc.uav, k)
        need(math.isfinite(v) and v >= 0, f"uav.{k}", ">= 0")
    need(math.isnan(sc.paper_mean_error_m) or sc.paper_mean_error_m > 0, "paper_mean_error_m", "> 0 or nan")


def off_nadir_deg(roll_deg: float, pitch_deg: float) -> float:
    """Angle between the optical axis and the vertical for a gimbal roll and pitch (uvteam.camera):
    cos(angle) = cos(roll) cos(pitch)."""
    c = math.cos(math.radians(roll_deg)) * math.cos(math.radians(pitch_deg))
    return math.degrees(math.acos(max(-1.0, min(1.0, c))))


def _validate_optional(sc: Scenario, src: str) -> None:
    """The optional sections and fields: ranges, words, counts (files are checked where they are read:
    :func:`uvteam.io.files.load_scenario`)."""

    def need(cond: bool, key: str, why: str) -> None:
        if not cond:
            raise ConfigError(src, key, why)

    def inside(v: float, lo: float, hi: float) -> bool:
        return math.isfinite(v) and lo <= v <= hi

    u = sc.uav
    for k in ("tilt_roll_deg", "tilt_pitch_deg"):
        need(inside(getattr(u, k), -MAX_TILT_DEG, MAX_TILT_DEG), f"uav.{k}", f"-{MAX_TILT_DEG:g} to {MAX_TILT_DEG:g} deg")
    need(inside(u.attitude_sigma_deg, 0.0, MAX_ATTITUDE_SIGMA_DEG), "uav.attitude_sigma_deg",
         f"0-{MAX_ATTITUDE_SIGMA_DEG:g} deg; got {u.attitude_sigma_deg!r}")
    tilt = off_nadir_deg(u.tilt_roll_deg, u.tilt_pitch_deg)
    need(tilt <= MAX_TILT_DEG + 1e-9, "uav.tilt_roll_deg",
         f"roll and pitch together tilt the camera {tilt:.2f} deg off nadir; at most {MAX_TILT_DEG:g}")
    g = sc.ground
    need(g.texture in GROUND_TEXTURES, "ground.texture", f"one of {', '.join(GROUND_TEXTURES)}; got {g.texture!r}")
    need(g.texel_m == 0 or inside(g.texel_m, *TEXEL_RANGE_M), "ground.texel_m",
         f"0 (the nadir pixel footprint) or {TEXEL_RANGE_M[0]:g}-{TEXEL_RANGE_M[1]:g} m; got {g.texel_m!r}")
    need(inside(g.tile_m, *TILE_RANGE_M), "ground.tile_m", f"{TILE_RANGE_M[0]:g}-{TILE_RANGE_M[1]:g} m; got {g.tile_m!r}")
    if g.texture == "imagery":
        need(len(g.imagery) >= 1, "ground.imagery", 'texture = "imagery" needs at least one [[ground.imagery]] (path, gsd_m)')
    else:
        need(len(g.imagery) == 0, "ground.imagery", f'given, but ground.texture is {g.texture!r}: set texture = "imagery"')
    for i, s in enumerate(g.imagery):
        need(s.path.strip() != "", f"ground.imagery[{i}].path", "empty")
        need(inside(s.gsd_m, *IMAGERY_GSD_RANGE_M), f"ground.imagery[{i}].gsd_m",
             f"{IMAGERY_GSD_RANGE_M[0]:g}-{IMAGERY_GSD_RANGE_M[1]:g} m per pixel; got {s.gsd_m!r}")
    d = sc.distractors
    for k in ("on_route", "near_crowd", "scattered"):
        need(0 <= getattr(d, k) <= MAX_DISTRACTORS, f"distractors.{k}", f"0-{MAX_DISTRACTORS}; got {getattr(d, k)!r}")
    need(inside(d.near_crowd_m, 0.0, 200.0), "distractors.near_crowd_m", f"0-200 m; got {d.near_crowd_m!r}")
    need(len(d.kinds) >= 1 and all(k in DISTRACTOR_KINDS for k in d.kinds), "distractors.kinds",
         f"a non-empty list of {', '.join(DISTRACTOR_KINDS)}; got {list(d.kinds)!r}")
    need(all(c in COLORS for c in d.colors), "distractors.colors",
         f"label colours ({', '.join(COLORS)}), or [] for the UGVs' own; got {list(d.colors)!r}")
    lens = sc.lens
    need(lens.prefilter in PREFILTERS, "lens.prefilter", f"one of {', '.join(PREFILTERS)}; got {lens.prefilter!r}")
    need(lens.objects in OBJECT_FILLS, "lens.objects", f"one of {', '.join(OBJECT_FILLS)}; got {lens.objects!r}")
    need(inside(lens.blur_sigma_px, 0.0, MAX_BLUR_SIGMA_PX), "lens.blur_sigma_px",
         f"0-{MAX_BLUR_SIGMA_PX:g} px; got {lens.blur_sigma_px!r}")
