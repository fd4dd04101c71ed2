"""The team's picture as a ground station sees it: the crowds each localizer reports now, each vehicle's
latest fix, and the tracks of both. Pure: messages and the time come in as arguments.

A crowd is named by a uid stable for its track, ``uvteam.<team>.<source>.crowd.<crowd_id>``, where the
source is the localizer that reported it (``Crowds.vehicle``) and ``crowd_id`` the localizer's track id.
Each Crowds message is the whole set of its source's crowds in one frame: crowds missing from it are
gone. A crowd also leaves the snapshot when its source has said nothing for ``max_age_s``. Messages older
than the newest already taken from the same source or vehicle are ignored (zenoh may reorder across
routes). Tracks keep one point per ``track_period_s`` (a localizer reports at the camera's rate, an
autopilot at 10 Hz) and the last ``max_track_points`` of them for each crowd and vehicle.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

from ..messages import Crowd, Crowds, Fix, Status

__all__ = ["CrowdSeen", "VehicleSeen", "TrackPoint", "Snapshot", "Picture", "crowd_uid", "vehicle_uid"]


def crowd_uid(team: str, source: str, crowd_id: int) -> str:
    return f"uvteam.{team}.{source}.crowd.{crowd_id}"


def vehicle_uid(team: str, vehicle: str) -> str:
    return f"uvteam.{team}.{vehicle}"


@dataclass(frozen=True, slots=True)
class CrowdSeen:
    """One crowd as last reported: the message's Crowd with where and when it was seen."""

    uid: str
    team: str
    source: str             # the localizer (Crowds.vehicle)
    stamp_s: float          # capture time of the frame it was seen in
    crowd: Crowd


@dataclass(frozen=True, slots=True)
class VehicleSeen:
    uid: str
    team: str
    role: str               # "uav", "ugv", ... from the vehicle's Status.service; "" until one is seen
    fix: Fix                # heading_deg may be None (unknown)


@dataclass(frozen=True, slots=True)
class TrackPoint:
    stamp_s: float
    lat_deg: float
    lon_deg: float
    alt_amsl_m: float | None = None     # None for crowds (on the ground, height unknown)


@dataclass(frozen=True, slots=True)
class Snapshot:
    team: str
    stamp_s: float                      # the newest capture time in it (0.0 when empty)
    crowds: tuple[CrowdSeen, ...]
    vehicles: tuple[VehicleSeen, ...]


class Picture:
    def __init__(self, team: str, max_age_s: float = 5.0, max_track_points: int = 3600,
                 track_period_s: float = 1.0) -> None:
        if not max_age_s > 0.0:
            raise ValueError(f"max_age_s must be > 0, got {max_age_s!r}")
        if max_track_points < 1:
            raise ValueError(f"max_track_points must be >= 1, got {max_track_points!r}")
        if not track_period_s >= 0.0:
            raise ValueError(f"track_period_s must be >= 0, got {track_period_s!r}")
        self.team, self.max_age_s, self.max_track_points = team, float(max_age_s), int(max_track_points)
        self.track_period_s = float(track_period_s)
        self._crowds: dict[str, tuple[float, tuple[CrowdSeen, ...]]] = {}     # source -> (stamp, crowds)
        self._vehicles: dict[str, VehicleSeen] = {}
        self._roles: dict[str, str] = {}
        self._crowd_tracks: dict[str, deque] = {}
        self._vehicle_tracks: dict[str, deque] = {}

    def add_crowds(self, msg: Crowds) -> tuple[CrowdSeen, ...]:
        """Take a Crowds message; returns its crowds as records (empty if it was out of date)."""
        last = self._crowds.get(msg.vehicle)
        if last is not None and msg.stamp_s < last[0]:
            return ()
        seen = tuple(CrowdSeen(crowd_uid(self.team, msg.vehicle, c.crowd_id), self.team, msg.vehicle, msg.stamp_s, c)
                     for c in msg.crowds)
        self._crowds[msg.vehicle] = (msg.stamp_s, seen)
        for s in seen:
            self._append(self._crowd_tracks, s.uid, TrackPoint(s.stamp_s, s.crowd.lat_deg, s.crowd.lon_deg))
        return seen

    def add_fix(self, msg: Fix) -> VehicleSeen | None:
        """Take a Fix; returns the vehicle's record (None if it was out of date)."""
        last = self._vehicles.get(msg.vehicle)
        if last is not None and msg.stamp_s < last.fix.stamp_s:
            return None
        v = VehicleSeen(vehicle_uid(self.team, msg.vehicle), self.team, self._roles.get(msg.vehicle, ""), msg)
        self._vehicles[msg.vehicle] = v
        self._append(self._vehicle_tracks, msg.vehicle,
                     TrackPoint(msg.stamp_s, msg.lat_deg, msg.lon_deg, msg.alt_amsl_m))
        return v

    def add_status(self, msg: Status) -> None:
        """Learn a vehicle's role from the service that reports for it."""
        if msg.service in ("uav", "ugv"):
            self._roles[msg.vehicle] = msg.service
            v = self._vehicles.get(msg.vehicle)
            if v is not None and v.role != msg.service:
                self._vehicles[msg.vehicle] = VehicleSeen(v.uid, v.team, msg.service, v.fix)

    def snapshot(self, now_s: float) -> Snapshot:
        """Crowds reported within ``max_age_s`` of ``now_s`` (sorted by uid) and every vehicle's latest fix."""
        crowds = sorted((c for stamp, cs in self._crowds.values() if now_s - stamp <= self.max_age_s for c in cs),
                        key=lambda c: c.uid)
        vehicles = tuple(self._vehicles[k] for k in sorted(self._vehicles))
        stamps = [c.stamp_s for c in crowds] + [v.fix.stamp_s for v in vehicles]
        return Snapshot(self.team, max(stamps, default=0.0), tuple(crowds), vehicles)

    def crowd_tracks(self) -> dict[str, tuple[TrackPoint, ...]]:
        """Every crowd uid ever seen -> its points, oldest first."""
        return {k: tuple(v) for k, v in sorted(self._crowd_tracks.items())}

    def vehicle_tracks(self) -> dict[str, tuple[TrackPoint, ...]]:
        """Every vehicle id -> its fixes, oldest first."""
        return {k: tuple(v) for k, v in sorted(self._vehicle_tracks.items())}

    def _append(self, tracks: dict[str, deque], key: str, p: TrackPoint) -> None:
        d = tracks.get(key)
        if d is None:
            d = tracks[key] = deque(maxlen=self.max_track_points)
        if d and (p.stamp_s <= d[-1].stamp_s or p.stamp_s - d[-1].stamp_s < self.track_period_s):
            return                                 # time strictly increasing, one point per track_period_s
        d.append(p)
