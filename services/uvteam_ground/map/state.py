"""What the live map shows of one team, built from bus messages: no zenoh, no clock, no HTTP.

    view = TeamView(MapConfig(team="demo"))
    view.on_fix(key, fix, now_s)            # from the bus handlers (any thread)
    view.on_crowds(key, crowds, now_s)
    view.snapshot(now_s)                    # -> plain data, JSON-ready, sent to the browsers

Vehicles:
- the UAV (``MapConfig.uav``, else the vehicle that publishes ``detections``, else an id starting
  with "uav") with its camera footprint on the ground: a rectangle centred under it (nadir camera),
  ``hfov_deg`` wide, with the image's aspect, turned by the UAV's heading (the camera is fixed to
  the body; a north-up gimbal: ``footprint_yaw="north"``). Its height above ground comes from the
  UAV's last ``Detections`` (``alt_agl_m``, ``width_px`` x ``height_px``: the altitude the detector
  itself used) while they are fresh, else from the fix's ``alt_amsl_m`` minus ``ground_amsl_m`` when
  that is configured; with neither there is no footprint. The snapshot says which (``footprint_source``).
- every other vehicle with a fix is a UGV: position, heading (None = unknown: no arrow), trail, plan.
- services without a fix (the localizer) appear in the list only, with their liveliness and status.
Alive is the liveliness token (None until the watcher has said anything); stale is "not alive, or
the last fix older than ``stale_s``" (age from the fix's own capture stamp).

Crowds: the last ``Crowds`` message of each source is the current set; a crowd missing from it is
kept ``crowd_keep_s`` as lost (drawn faded) with its track, then dropped.
"""

from __future__ import annotations

import math
import threading
from collections import deque
from dataclasses import dataclass, field
from typing import Any

from uvteam import keys
from uvteam.camera import PinholeCamera
from uvteam.errors import ConfigError
from uvteam.geo import LocalFrame
from uvteam.mgrs import latlon_to_mgrs

__all__ = ["MapConfig", "TeamView", "camera_footprint_latlon", "offset_latlon", "ground_distance_m"]

_A_M = 6378137.0
_E2 = 6.69437999014e-3


def _radii_m(lat_deg: float) -> tuple[float, float]:
    """Metres per radian of latitude (meridian) and of longitude (parallel) on WGS84 at this latitude."""
    s2 = math.sin(math.radians(lat_deg)) ** 2
    w = math.sqrt(1.0 - _E2 * s2)
    return _A_M * (1.0 - _E2) / w**3, _A_M / w * math.cos(math.radians(lat_deg))


def offset_latlon(lat_deg: float, lon_deg: float, east_m: float, north_m: float) -> tuple[float, float]:
    """A point ``east_m, north_m`` from (lat, lon): the local flat-earth step (1 mm at 100 m)."""
    m_lat, m_lon = _radii_m(lat_deg)
    return lat_deg + math.degrees(north_m / m_lat), lon_deg + math.degrees(east_m / max(m_lon, 1e-9))


def ground_distance_m(a: tuple[float, float], b: tuple[float, float]) -> float:
    m_lat, m_lon = _radii_m((a[0] + b[0]) / 2.0)
    return math.hypot(math.radians(b[0] - a[0]) * m_lat, math.radians(b[1] - a[1]) * m_lon)


def camera_footprint_latlon(lat_deg: float, lon_deg: float, alt_agl_m: float, hfov_deg: float, width_px: int,
                            height_px: int, yaw_deg: float = 0.0) -> tuple[tuple[float, float], ...]:
    """The ground a nadir camera at (lat, lon, alt_agl_m) sees, as four (lat_deg, lon_deg) corners:
    image top-left, top-right, bottom-right, bottom-left. At ``yaw_deg`` 0 the image top is north
    (uvteam.camera's convention); yaw turns it clockwise. Flat ground at the camera's foot."""
    if not (math.isfinite(alt_agl_m) and alt_agl_m > 0.0):
        raise ValueError(f"alt_agl_m must be a finite height above 0, got {alt_agl_m}")
    w_m, h_m = PinholeCamera(int(width_px), int(height_px), hfov_deg).footprint_m(alt_agl_m)
    y = math.radians(yaw_deg)
    frame = LocalFrame(lat_deg, lon_deg)
    out = []
    for right_m, up_m in ((-w_m / 2, h_m / 2), (w_m / 2, h_m / 2), (w_m / 2, -h_m / 2), (-w_m / 2, -h_m / 2)):
        east, north = right_m * math.cos(y) + up_m * math.sin(y), -right_m * math.sin(y) + up_m * math.cos(y)
        lat, lon = frame.ground_to_wgs84(east, north)
        out.append((float(lat), float(lon)))
    return tuple(out)


@dataclass(frozen=True, slots=True)
class MapConfig:
    team: str
    uav: str | None = None              # the UAV's id; None: the vehicle that publishes detections
    hfov_deg: float = 78.0              # the UAV camera's horizontal field of view
    image_width_px: int = 1280          # image aspect for the fix-based footprint
    image_height_px: int = 720
    ground_amsl_m: float | None = None  # ground height, for the fix-based footprint (None: no such footprint)
    footprint_yaw: str = "heading"      # "heading": the camera turns with the UAV; "north": north-up gimbal
    stale_s: float = 3.0                # a fix older than this (or a vehicle not alive) is drawn stale
    trail_points: int = 600             # UGV trail and crowd track length
    trail_step_m: float = 0.5           # a new trail point once the vehicle moved this far
    arrow_s: float = 5.0                # velocity arrows end where the crowd is in this many seconds
    crowd_keep_s: float = 10.0          # a crowd no longer reported is drawn as lost this long
    origin: tuple[float, float] | None = None   # grid origin; None: the first fix

    def __post_init__(self) -> None:
        keys.check_id("team", self.team)
        if self.uav is not None:
            keys.check_id("vehicle", self.uav)
        checks = [("hfov_deg", 0.0 < self.hfov_deg < 180.0, "in (0, 180)"),
                  ("image_width_px", self.image_width_px > 0, "> 0"),
                  ("image_height_px", self.image_height_px > 0, "> 0"),
                  ("stale_s", self.stale_s > 0.0, "> 0"),
                  ("trail_points", self.trail_points >= 2, ">= 2"),
                  ("trail_step_m", self.trail_step_m >= 0.0, ">= 0"),
                  ("arrow_s", self.arrow_s > 0.0, "> 0"),
                  ("crowd_keep_s", self.crowd_keep_s >= 0.0, ">= 0"),
                  ("footprint_yaw", self.footprint_yaw in ("heading", "north"), "'heading' or 'north'")]
        if self.ground_amsl_m is not None:
            checks.append(("ground_amsl_m", math.isfinite(self.ground_amsl_m), "finite"))
        if self.origin is not None:
            checks.append(("origin", -90 <= self.origin[0] <= 90 and -180 <= self.origin[1] <= 180,
                           "lat in [-90, 90], lon in [-180, 180]"))
        for name, ok, want in checks:
            if not ok:
                raise ConfigError("uvteam map", name, f"must be {want}, got {getattr(self, name)!r}")


def _r(x: float, nd: int = 7) -> float:
    return round(float(x), nd)


@dataclass
class _Vehicle:
    fix: Any = None
    fix_at_s: float = 0.0
    alive: bool | None = None
    status: Any = None
    plan: Any = None
    detections: Any = None          # (width_px, height_px, alt_agl_m, stamp_s)
    trail: deque = field(default_factory=deque)


@dataclass
class _CrowdRec:
    crowd: Any
    stamp_s: float
    source: str
    track: deque
    last_seen_s: float
    lost: bool = False


class TeamView:
    """Thread-safe picture of the team. ``changed`` is notified on every update (the server waits on it)."""

    def __init__(self, cfg: MapConfig) -> None:
        self.cfg = cfg
        self.changed = threading.Condition()
        self.version = 0
        self._vehicles: dict[str, _Vehicle] = {}
        self._crowds: dict[tuple[str, int], _CrowdRec] = {}
        self._frame: dict[str, Any] = {}          # source -> last Crowds (its frame-level fields)
        self._origin = cfg.origin

    # -- updates (bus handler threads) --------------------------------------------------------------
    def _veh(self, key: str) -> tuple[str, _Vehicle]:
        v = keys.vehicle_of(key) or key
        return v, self._vehicles.setdefault(v, _Vehicle(trail=deque(maxlen=self.cfg.trail_points)))

    def _bump(self) -> None:
        self.version += 1
        self.changed.notify_all()

    def on_fix(self, key: str, fix: Any, now_s: float) -> None:
        with self.changed:
            _, v = self._veh(key)
            v.fix, v.fix_at_s = fix, now_s
            p = (fix.lat_deg, fix.lon_deg)
            if not v.trail or ground_distance_m(v.trail[-1], p) >= self.cfg.trail_step_m:
                v.trail.append(p)
            if self._origin is None:
                self._origin = p
            self._bump()

    def on_alive(self, key: str, up: bool, now_s: float) -> None:
        with self.changed:
            self._veh(key)[1].alive = bool(up)
            self._bump()

    def on_status(self, key: str, status: Any, now_s: float) -> None:
        with self.changed:
            self._veh(key)[1].status = status
            self._bump()

    def on_plan(self, key: str, plan: Any, now_s: float) -> None:
        with self.changed:
            self._veh(key)[1].plan = plan
            self._bump()

    def on_detections(self, key: str, det: Any, now_s: float) -> None:
        # only the frame-level fields: Detections' per-blob layout may change, these stay
        with self.changed:
            self._veh(key)[1].detections = (int(det.width_px), int(det.height_px), float(det.alt_agl_m),
                                            float(det.stamp_s))
            self._bump()

    def on_crowds(self, key: str, msg: Any, now_s: float) -> None:
        source = keys.vehicle_of(key) or key
        with self.changed:
            self._frame[source] = msg
            seen = set()
            for c in msg.crowds:
                k = (source, int(c.crowd_id))
                seen.add(k)
                rec = self._crowds.get(k)
                if rec is None:
                    rec = self._crowds[k] = _CrowdRec(c, msg.stamp_s, source, deque(maxlen=self.cfg.trail_points), now_s)
                rec.crowd, rec.stamp_s, rec.last_seen_s, rec.lost = c, msg.stamp_s, now_s, False
                p = (c.lat_deg, c.lon_deg)
                if not rec.track or ground_distance_m(rec.track[-1], p) >= self.cfg.trail_step_m:
                    rec.track.append(p)
            for k, rec in list(self._crowds.items()):
                if k[0] == source and k not in seen:
                    rec.lost = True
            self._bump()

    # -- reading ------------------------------------------------------------------------------------
    def _uav_id(self) -> str | None:
        if self.cfg.uav is not None:
            return self.cfg.uav
        with_det = sorted(v for v, rec in self._vehicles.items() if rec.detections is not None)
        if with_det:
            return with_det[0]
        named = sorted(v for v, rec in self._vehicles.items() if v.lower().startswith("uav") and rec.fix is not None)
        return named[0] if named else None

    def _footprint(self, rec: _Vehicle, now_s: float) -> tuple[list | None, str | None, bool]:
        f = rec.fix
        heading = getattr(f, "heading_deg", None)
        yaw_known = self.cfg.footprint_yaw == "north" or heading is not None
        yaw = heading if (self.cfg.footprint_yaw == "heading" and heading is not None) else 0.0
        if rec.detections is not None and now_s - rec.detections[3] <= self.cfg.stale_s and rec.detections[2] > 0:
            w, h, alt, _ = rec.detections
            source = "detections"
        elif self.cfg.ground_amsl_m is not None and f.alt_amsl_m - self.cfg.ground_amsl_m > 0:
            w, h, alt = self.cfg.image_width_px, self.cfg.image_height_px, f.alt_amsl_m - self.cfg.ground_amsl_m
            source = "fix"
        else:
            return None, None, yaw_known
        corners = camera_footprint_latlon(f.lat_deg, f.lon_deg, alt, self.cfg.hfov_deg, w, h, yaw)
        return [[_r(a), _r(b)] for a, b in corners], source, yaw_known

    @staticmethod
    def _status(st: Any, now_s: float) -> dict | None:
        if st is None:
            return None
        return {"service": st.service, "link": st.link, "rejected": st.rejected, "published": st.published,
                "received": st.received, "note": st.note, "metrics": {k: _r(v, 3) for k, v in st.metrics.items()},
                "age_s": _r(max(now_s - st.stamp_s, 0.0), 2)}

    def snapshot(self, now_s: float) -> dict:
        """The whole picture as plain data (lists, numbers, strings, None)."""
        cfg = self.cfg
        with self.changed:
            uav = self._uav_id()
            vehicles = []
            for vid in sorted(self._vehicles):
                rec = self._vehicles[vid]
                f = rec.fix
                out: dict[str, Any] = {"id": vid, "alive": rec.alive, "status": self._status(rec.status, now_s)}
                if f is None:
                    out.update(role="service", stale=rec.alive is not True)
                    vehicles.append(out)
                    continue
                age = max(now_s - f.stamp_s, 0.0)
                heading = getattr(f, "heading_deg", None)
                ve, vn = getattr(f, "v_east_m_s", None), getattr(f, "v_north_m_s", None)   # None: unknown
                out.update(role="uav" if vid == uav else "ugv", lat=_r(f.lat_deg), lon=_r(f.lon_deg),
                           alt_amsl_m=_r(f.alt_amsl_m, 2), heading_deg=None if heading is None else _r(heading, 1),
                           h_acc_m=_r(f.h_acc_m, 2), age_s=_r(age, 2),
                           speed_m_s=None if ve is None or vn is None else _r(math.hypot(ve, vn), 2),
                           stale=rec.alive is False or age > cfg.stale_s,
                           mgrs=latlon_to_mgrs(f.lat_deg, f.lon_deg, 5),
                           trail=[[_r(a), _r(b)] for a, b in rec.trail])
                if rec.plan is not None and rec.plan.waypoints:
                    out["plan"] = [[_r(f.lat_deg), _r(f.lon_deg)]] + [[_r(w.lat_deg), _r(w.lon_deg)]
                                                                       for w in rec.plan.waypoints]
                else:
                    out["plan"] = []
                if vid == uav:
                    fp, src, yaw_known = self._footprint(rec, now_s)
                    out.update(footprint=fp, footprint_source=src, footprint_yaw_known=yaw_known)
                vehicles.append(out)
            for k in [k for k, rec in self._crowds.items() if rec.lost and now_s - rec.last_seen_s > cfg.crowd_keep_s]:
                del self._crowds[k]
            crowds = [self._crowd_out(rec, now_s) for _, rec in sorted(self._crowds.items())]
            frames = {src: {"quality": m.quality, "landmarks_used": list(m.landmarks_used),
                            "outlier_landmarks": list(m.outlier_landmarks), "n_crowds": len(m.crowds),
                            "age_s": _r(max(now_s - m.stamp_s, 0.0), 2)} for src, m in sorted(self._frame.items())}
            return {"team": cfg.team, "now_s": _r(now_s, 3), "version": self.version,
                    "origin": None if self._origin is None else [_r(self._origin[0]), _r(self._origin[1])],
                    "stale_s": cfg.stale_s, "vehicles": vehicles, "crowds": crowds, "frames": frames}

    def _crowd_out(self, rec: _CrowdRec, now_s: float) -> dict:
        c, cfg = rec.crowd, self.cfg
        speed = math.hypot(c.v_east_m_s, c.v_north_m_s)
        tip = offset_latlon(c.lat_deg, c.lon_deg, c.v_east_m_s * cfg.arrow_s, c.v_north_m_s * cfg.arrow_s)
        age = max(now_s - rec.stamp_s, 0.0)
        return {"id": int(c.crowd_id), "source": rec.source, "lat": _r(c.lat_deg), "lon": _r(c.lon_deg),
                "mgrs": latlon_to_mgrs(c.lat_deg, c.lon_deg, 5), "radius95_m": _r(c.radius95_m, 2),
                "quality": c.quality, "n_outliers": int(c.n_outliers), "unseen_s": _r(c.unseen_s, 1),
                "footprint": [[_r(a), _r(b)] for a, b in zip(c.footprint_lat_deg, c.footprint_lon_deg)],
                "v_east_m_s": _r(c.v_east_m_s, 2), "v_north_m_s": _r(c.v_north_m_s, 2), "speed_m_s": _r(speed, 2),
                "arrow_tip": [_r(tip[0]), _r(tip[1])] if speed >= 0.05 else None, "arrow_s": cfg.arrow_s,
                "track": [[_r(a), _r(b)] for a, b in rec.track], "age_s": _r(age, 2), "lost": rec.lost,
                "stale": rec.lost or age > cfg.stale_s}
