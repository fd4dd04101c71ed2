"""Pure: station plans <-> MAVLink missions, and a mission -> the plan (waypoints with times).

A leg's speed travels as MAV_CMD_DO_CHANGE_SPEED (param1 = 1 ground speed, param2 = m/s, param3 = -1
throttle unchanged) before its MAV_CMD_NAV_WAYPOINT, which any standard autopilot honours; the plan's
times follow from the vehicle's position, the legs' lengths and their speeds.

Frames: DO_CHANGE_SPEED travels in MAV_FRAME_MISSION and NAV_WAYPOINT in MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
frames both PX4 and ArduPilot accept for these commands (their mission parsers are cited at
:data:`uvteam.autopilot.POSITIONAL_COMMANDS`). The items here are the vehicle's mission as the service
means it; the autopilot's own conventions (ArduPilot's home at seq 0, the ``current`` flag) are applied
and removed by the link, so a downloaded mission gives the same plan on either stack.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .autopilot import FRAME_GLOBAL_INT, FRAME_MISSION, MAV_CMD_DO_CHANGE_SPEED, MAV_CMD_NAV_WAYPOINT, MissionItem
from .geo import LocalFrame
from .messages import Plan, Waypoint
from .planning import StationPlan

__all__ = ["plan_to_mission", "mission_to_plan", "mission_legs", "Leg"]


def plan_to_mission(plan: StationPlan, frame: LocalFrame) -> list[MissionItem]:
    lat, lon = frame.ground_to_wgs84(plan.en_m[:, 0], plan.en_m[:, 1])
    items: list[MissionItem] = []
    for la, lo, sp in zip(np.atleast_1d(lat), np.atleast_1d(lon), plan.speed_m_s):
        items.append(MissionItem(MAV_CMD_DO_CHANGE_SPEED, param1=1.0, param2=float(sp), param3=-1.0,
                                 frame=FRAME_MISSION))
        items.append(MissionItem(MAV_CMD_NAV_WAYPOINT, float(la), float(lo), 0.0, frame=FRAME_GLOBAL_INT))
    return items


@dataclass(frozen=True, slots=True)
class Leg:
    """A mission leg: where it ends and the speed commanded on it."""

    lat_deg: float
    lon_deg: float
    speed_m_s: float


def mission_legs(items: list[MissionItem], default_speed_m_s: float) -> list[Leg]:
    """The waypoints of a mission with the speed in force on the leg to each (a DO_CHANGE_SPEED holds
    until the next one; before the first, ``default_speed_m_s``)."""
    speed, legs = default_speed_m_s, []
    for it in items:
        if it.command == MAV_CMD_DO_CHANGE_SPEED and it.param2 > 0:
            speed = float(it.param2)
        elif it.command == MAV_CMD_NAV_WAYPOINT:
            legs.append(Leg(it.lat_deg, it.lon_deg, speed))
    return legs


def mission_to_plan(vehicle: str, items: list[MissionItem], frame: LocalFrame, start_en_m, now_s: float,
                    default_speed_m_s: float) -> Plan:
    """The plan a mission makes: each waypoint with the time the vehicle reaches it from ``start_en_m``."""
    pos = np.asarray(start_en_m, float)
    t = now_s
    wps = []
    for leg in mission_legs(items, default_speed_m_s):
        e, n = frame.wgs84_to_ground(leg.lat_deg, leg.lon_deg)
        nxt = np.array([float(e), float(n)])
        t += float(np.hypot(*(nxt - pos))) / max(leg.speed_m_s, 0.05)
        pos = nxt
        wps.append(Waypoint(t, leg.lat_deg, leg.lon_deg))
    return Plan(vehicle, now_s, tuple(wps))
