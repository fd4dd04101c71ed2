"""Crowds as MAVLink 2 ADSB_VEHICLE traffic: for QGroundControl and Mission Planner.

Both ground stations draw ADSB_VEHICLE (MAVLink message 246) on their map as air traffic, and nothing
else a third party can send draws an arbitrary point on both (docs/formats.md cites the code):
QGroundControl hands ADSB_VEHICLE to its ADSBVehicleManager only from a system id that QGC already has
as a vehicle (Vehicle::_mavlinkMessageReceived drops other system ids), needs ADSB_FLAGS_VALID_COORDS to
add one, drops tslc > 15 s and removes an entry after 120 s without update; Mission Planner takes it from
any system and component and draws it for 30 s after its last update.

Per crowd one ADSB_VEHICLE: ICAO_address ``icao_base + (crc32(source) % 16) * 65536 + crowd_id % 65536``
(stable per crowd track), lat/lon in 1e-7 degrees, callsign ``CR<crowd_id>`` (8 characters at most),
heading (cdeg) and hor_velocity (cm/s) from the crowd's velocity with their VALID flags when it moves
faster than 0.1 m/s, tslc the seconds since the frame it was seen in, emitter type POINT_OBSTACLE
(a thing on the surface), altitude not valid (a crowd's height is not known; the flag stays clear,
altitude 0). The 95 % circle and the footprint cannot be carried by ADSB_VEHICLE.

The sender is MAVLink system ``sysid``, component ``compid`` (default 191, MAV_COMP_ID_ONBOARD_COMPUTER),
with a 1 Hz HEARTBEAT: MAV_TYPE_ONBOARD_CONTROLLER, which neither ground station takes for a vehicle;
with compid 1 (MAV_COMP_ID_AUTOPILOT1) the heartbeat says MAV_TYPE_GENERIC instead, the only way to make
a QGC with no autopilot connected create a vehicle for this system id and so draw its traffic.

Never route this stream to an autopilot: ArduPilot's ADS-B avoidance (AVD_ENABLE) acts on
ADSB_VEHICLE traffic.
"""

from __future__ import annotations

import zlib

from pymavlink.dialects.v20 import common as mavlink2

from ._geometry import course_speed
from .picture import CrowdSeen, Snapshot

__all__ = ["AdsbEncoder", "icao_address", "adsb_message", "DEFAULT_ICAO_BASE", "DEFAULT_COMPID"]

DEFAULT_ICAO_BASE = 0xF00000
DEFAULT_COMPID = mavlink2.MAV_COMP_ID_ONBOARD_COMPUTER      # 191
_MAX_TSLC_S = 255


def icao_address(c: CrowdSeen, icao_base: int = DEFAULT_ICAO_BASE) -> int:
    """A 24-bit address stable for the crowd's track: base + 16 sources x 65536 crowd ids."""
    return (icao_base + ((zlib.crc32(c.source.encode()) % 16) << 16) + (c.crowd.crowd_id % 65536)) & 0xFFFFFF


def adsb_message(c: CrowdSeen, now_s: float, icao_base: int = DEFAULT_ICAO_BASE):
    """The ADSB_VEHICLE message for one crowd (a pymavlink message object; pack it with an encoder)."""
    cr = c.crowd
    course, speed = course_speed(cr.v_east_m_s, cr.v_north_m_s)
    flags = mavlink2.ADSB_FLAGS_VALID_COORDS | mavlink2.ADSB_FLAGS_VALID_CALLSIGN
    heading_cdeg = hor_cm_s = 0
    if course is not None:
        flags |= mavlink2.ADSB_FLAGS_VALID_HEADING | mavlink2.ADSB_FLAGS_VALID_VELOCITY
        heading_cdeg = int(round(course * 100.0)) % 36000
        hor_cm_s = min(int(round(speed * 100.0)), 65535)
    tslc = int(min(max(now_s - c.stamp_s, 0.0), _MAX_TSLC_S))
    return mavlink2.MAVLink_adsb_vehicle_message(
        icao_address(c, icao_base), int(round(cr.lat_deg * 1e7)), int(round(cr.lon_deg * 1e7)),
        mavlink2.ADSB_ALTITUDE_TYPE_GEOMETRIC, 0, heading_cdeg, hor_cm_s, 0, f"CR{cr.crowd_id}"[:8].encode("ascii"),
        mavlink2.ADSB_EMITTER_TYPE_POINT_OBSTACLE, tslc, flags, 0)


class AdsbEncoder:
    """Packs MAVLink 2 frames from one system/component, with its own sequence numbers. In memory only."""

    def __init__(self, sysid: int = 1, compid: int = DEFAULT_COMPID, icao_base: int = DEFAULT_ICAO_BASE) -> None:
        if not 1 <= sysid <= 255:
            raise ValueError(f"sysid must be 1-255, got {sysid!r}")
        if not 1 <= compid <= 255:
            raise ValueError(f"compid must be 1-255, got {compid!r}")
        if not 0 <= icao_base <= 0xFFFFFF:
            raise ValueError(f"icao_base must be a 24-bit address, got {icao_base!r}")
        self.sysid, self.compid, self.icao_base = sysid, compid, icao_base
        self._mav = mavlink2.MAVLink(None, srcSystem=sysid, srcComponent=compid)

    def _pack(self, msg) -> bytes:
        raw = msg.pack(self._mav)
        self._mav.seq = (self._mav.seq + 1) % 256
        return bytes(raw)

    def heartbeat(self) -> bytes:
        mav_type = (mavlink2.MAV_TYPE_GENERIC if self.compid == mavlink2.MAV_COMP_ID_AUTOPILOT1
                    else mavlink2.MAV_TYPE_ONBOARD_CONTROLLER)
        return self._pack(mavlink2.MAVLink_heartbeat_message(mav_type, mavlink2.MAV_AUTOPILOT_INVALID, 0, 0,
                                                             mavlink2.MAV_STATE_ACTIVE, 3))

    def crowds(self, snap: Snapshot, now_s: float) -> list[bytes]:
        """One packed ADSB_VEHICLE frame per crowd in the snapshot (one UDP datagram each)."""
        return [self._pack(adsb_message(c, now_s, self.icao_base)) for c in snap.crowds]
