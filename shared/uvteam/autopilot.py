"""What a service needs of its vehicle's autopilot, and the values that cross it. Pure: no I/O.

:class:`Autopilot` is the interface the service logic (:mod:`uvteam.nodes`) is written against; the
MAVLink link (:class:`uvteam.io.mavlink.AutopilotLink`) is the real one, :class:`MemoryAutopilot` the
fake that the experiment and the unit tests drive. Raw MAVLink units are converted once, in the link;
everything here is SI with units in the names.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass
from typing import Callable, Protocol

from pymavlink.dialects.v20 import ardupilotmega as mavlink2

from .errors import LinkError

__all__ = ["VehicleState", "MissionItem", "fix_from_state", "Autopilot", "MemoryAutopilot", "mavlink2",
           "MAV_CMD_NAV_WAYPOINT", "MAV_CMD_DO_CHANGE_SPEED", "FRAME_GLOBAL_INT", "FRAME_MISSION",
           "GPS_FIX_3D", "default_frame"]

MAV_CMD_NAV_WAYPOINT = mavlink2.MAV_CMD_NAV_WAYPOINT            # 16
MAV_CMD_DO_CHANGE_SPEED = mavlink2.MAV_CMD_DO_CHANGE_SPEED      # 178
FRAME_GLOBAL_INT = mavlink2.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT   # 6: lat/lon 1e7 deg, altitude above home
FRAME_MISSION = mavlink2.MAV_FRAME_MISSION                      # 2: an item with no position
GPS_FIX_3D = mavlink2.GPS_FIX_TYPE_3D_FIX                       # 3; 0 no GPS, 1 no fix, 2 2D, 4+ DGPS/RTK/...

# Commands whose item carries a position (x = lat, y = lon, z = alt), so they travel in a global frame;
# every other command travels in MAV_FRAME_MISSION. Why (the autopilots' mission parsers, read 2026-12):
# - PX4 src/modules/mavlink/mavlink_mission.cpp, MavlinkMissionManager::parse_mavlink_mission_item: an item
#   in MAV_FRAME_GLOBAL[_RELATIVE_ALT][_INT] must be a positional command (NAV_WAYPOINT, NAV_LOITER_*,
#   NAV_LAND, NAV_TAKEOFF, ...) or the upload is refused with MAV_MISSION_UNSUPPORTED; DO_CHANGE_SPEED (and
#   the other DO_* commands) are accepted only in MAV_FRAME_MISSION; any other frame is
#   MAV_MISSION_UNSUPPORTED_FRAME. MAVSDK (PX4's SDK, mission_impl.cpp convert_to_int_items) sends
#   DO_CHANGE_SPEED as frame MISSION, param1 = 1 (ground speed), param2 = m/s, param3 = -1 (throttle as is).
# - ArduPilot libraries/AP_Mission/AP_Mission.cpp, AP_Mission::mavlink_int_to_mission_cmd: the frame is
#   only read for commands stored with a location (stored_in_location: NAV_WAYPOINT, NAV_LOITER_*, ...),
#   which accept MAV_FRAME_MISSION, GLOBAL[_INT], GLOBAL_RELATIVE_ALT[_INT] and TERRAIN_ALT[_INT]
#   (else MAV_MISSION_UNSUPPORTED_FRAME); DO_CHANGE_SPEED is accepted in any frame, MISSION included.
# So MISSION for DO_* and GLOBAL_RELATIVE_ALT_INT for positions is accepted by both stacks.
POSITIONAL_COMMANDS = frozenset({
    mavlink2.MAV_CMD_NAV_WAYPOINT, mavlink2.MAV_CMD_NAV_LOITER_UNLIM, mavlink2.MAV_CMD_NAV_LOITER_TURNS,
    mavlink2.MAV_CMD_NAV_LOITER_TIME, mavlink2.MAV_CMD_NAV_LAND, mavlink2.MAV_CMD_NAV_TAKEOFF,
    mavlink2.MAV_CMD_NAV_LOITER_TO_ALT,
})


def default_frame(command: int) -> int:
    """The MAV_FRAME that both PX4 and ArduPilot accept for a mission item of this command (see above)."""
    return FRAME_GLOBAL_INT if command in POSITIONAL_COMMANDS else FRAME_MISSION


@dataclass(frozen=True, slots=True)
class VehicleState:
    stamp_s: float                 # capture time (UNIX seconds)
    stamp_source: str              # "autopilot" (boot time + SYSTEM_TIME offset) or "arrival"
    lat_deg: float
    lon_deg: float
    alt_amsl_m: float
    alt_agl_m: float               # relative to home
    heading_deg: float | None      # None when the autopilot says unknown
    v_east_m_s: float
    v_north_m_s: float
    h_acc_m: float | None          # GPS_RAW_INT.h_acc (MAVLink 2 extension); None when not sent
    roll_deg: float | None = None
    pitch_deg: float | None = None
    yaw_deg: float | None = None
    fix_type: int | None = None    # GPS_RAW_INT.fix_type (GPS_FIX_TYPE: 0-1 none, 2 2D, 3 3D, 4+ better); None = not seen

    def usable_fix(self, max_h_acc_m: float) -> bool:
        """True when the GNSS says 3D fix or better and its horizontal accuracy is known and within
        ``max_h_acc_m``. Unknown fix type or accuracy is not usable: a position the autopilot cannot
        vouch for (dead reckoning, no GPS_RAW_INT seen, MAVLink 1 without h_acc) must not reach the map."""
        return (self.fix_type is not None and self.fix_type >= GPS_FIX_3D
                and self.h_acc_m is not None and self.h_acc_m <= max_h_acc_m)


def fix_from_state(vehicle: str, st: VehicleState, unknown_h_acc_m: float = 5.0):
    """The bus message for an autopilot state. An unknown heading stays unknown (None, never north);
    an unknown accuracy becomes a cautious ``unknown_h_acc_m``."""
    from .messages import Fix  # noqa: PLC0415

    return Fix(vehicle, st.stamp_s, st.lat_deg, st.lon_deg, st.alt_amsl_m,
               None if st.heading_deg is None else st.heading_deg % 360.0,
               st.h_acc_m if st.h_acc_m is not None else unknown_h_acc_m, st.v_east_m_s, st.v_north_m_s,
               getattr(st, "fix_type", None))


@dataclass(frozen=True, slots=True)
class MissionItem:
    """One MISSION_ITEM_INT in SI units. ``frame`` left out (None) becomes :func:`default_frame` of the
    command, the frame PX4 and ArduPilot both accept. ``current`` is the protocol's flag: on upload the
    link sets it per the autopilot's convention (see :meth:`uvteam.io.mavlink.AutopilotLink.upload_mission`);
    on download it is what the autopilot reported (1 = the item it is executing or will start from)."""

    command: int
    lat_deg: float = 0.0
    lon_deg: float = 0.0
    alt_m: float = 0.0
    param1: float = 0.0
    param2: float = 0.0
    param3: float = 0.0
    param4: float = 0.0
    frame: int | None = None
    autocontinue: int = 1
    current: int = 0

    def __post_init__(self) -> None:
        if self.frame is None:
            object.__setattr__(self, "frame", default_frame(self.command))

    def to_msg(self, seq: int, target_system: int, target_component: int) -> mavlink2.MAVLink_mission_item_int_message:
        return mavlink2.MAVLink_mission_item_int_message(
            target_system, target_component, seq, self.frame, self.command, self.current, self.autocontinue,
            self.param1, self.param2, self.param3, self.param4,
            int(round(self.lat_deg * 1e7)), int(round(self.lon_deg * 1e7)), float(self.alt_m),
            mavlink2.MAV_MISSION_TYPE_MISSION)

    @staticmethod
    def from_msg(m) -> "MissionItem":
        if m.get_type() == "MISSION_ITEM_INT":
            lat, lon = m.x * 1e-7, m.y * 1e-7
        else:  # legacy MISSION_ITEM with float degrees
            lat, lon = float(m.x), float(m.y)
        return MissionItem(m.command, lat, lon, float(m.z), m.param1, m.param2, m.param3, m.param4,
                           m.frame, m.autocontinue, m.current)


class Autopilot(Protocol):
    """A vehicle's autopilot as the services use it."""

    link_state: str                                     # "up" | "down"

    def state(self) -> VehicleState | None: ...         # the newest state, or None before the first
    def upload_mission(self, items: list[MissionItem]) -> None: ...   # LinkError unless accepted
    def download_mission(self) -> list[MissionItem]: ...               # LinkError when it cannot


class MemoryAutopilot:
    """An autopilot in memory: the state is what the caller last set; an uploaded mission is held and
    handed to ``on_mission`` (the simulated vehicle); ``fail_missions`` makes exchanges fail."""

    def __init__(self, on_mission: Callable[[list[MissionItem]], None] | None = None) -> None:
        self._state: VehicleState | None = None
        self._lock = threading.Lock()
        self.mission: list[MissionItem] = []
        self.on_mission = on_mission
        self.link_state = "up"
        self.fail_missions = False
        self.uploads = 0

    def set_state(self, st: VehicleState | None) -> None:
        with self._lock:
            self._state = st

    def state(self) -> VehicleState | None:
        with self._lock:
            return self._state

    def upload_mission(self, items: list[MissionItem]) -> None:
        if self.fail_missions:
            raise LinkError("memory", "mission upload timed out")
        self.mission = list(items)
        self.uploads += 1
        if self.on_mission is not None:
            self.on_mission(list(items))

    def download_mission(self) -> list[MissionItem]:
        if self.fail_missions:
            raise LinkError("memory", "no MISSION_COUNT in reply to MISSION_REQUEST_LIST")
        return list(self.mission)
