"""A simulated vehicle autopilot speaking MAVLink 2 over UDP, as ArduPilot or PX4 would to a companion.

It streams HEARTBEAT and SYSTEM_TIME (1 Hz), and on request of the simulator GLOBAL_POSITION_INT,
GPS_RAW_INT and ATTITUDE; it serves the mission protocol both ways:

- download: MISSION_REQUEST_LIST -> MISSION_COUNT; MISSION_REQUEST_INT / MISSION_REQUEST(seq) ->
  MISSION_ITEM_INT(seq); the client's MISSION_ACK ends it;
- upload: MISSION_COUNT(n) -> MISSION_REQUEST_INT(0..n-1), re-requested when an item is late ->
  MISSION_ACK(ACCEPTED), and the new mission replaces the old one (``on_mission`` is called); an item the
  stack would refuse ends the upload with that stack's MAV_MISSION_RESULT;
- commands: COMMAND_LONG -> COMMAND_ACK: MAV_CMD_DO_CHANGE_SPEED and MAV_CMD_REQUEST_MESSAGE are
  ACCEPTED (the requested message follows the ACK; a message it cannot send is FAILED, as ArduPilot's
  GCS_MAVLINK::handle_command_request_message answers), any other command UNSUPPORTED.

It plays the mission rules of the stack it announces in its HEARTBEAT (``autopilot``), as read in their
sources (see :data:`uvteam.autopilot.POSITIONAL_COMMANDS` for the frames):

- ArduPilot (MAV_AUTOPILOT_ARDUPILOTMEGA, the default): item 0 is HOME. What is uploaded at seq 0 is
  dropped, a download returns HOME there, and the mission (``self.mission``) is items 1..n-1. NaN or
  infinite params are refused (MAV_MISSION_INVALID_PARAMn; NAV_WAYPOINT may leave param4 NaN), a
  NAV_WAYPOINT must be in a global or MISSION frame and have a valid lat/lon, DO_CHANGE_SPEED may be in
  any frame. ``current`` is ignored on upload; a download marks the item being executed.
- PX4 (MAV_AUTOPILOT_PX4): NAV_WAYPOINT only in MAV_FRAME_GLOBAL[_RELATIVE_ALT][_INT], DO_CHANGE_SPEED
  only in MAV_FRAME_MISSION (else MAV_MISSION_UNSUPPORTED), other frames MAV_MISSION_UNSUPPORTED_FRAME.
  The uploaded item marked ``current`` is where the mission starts (``current_seq``, -1 when none was
  marked) and downloads mark it again.

Only messages addressed to this system (and to its component, 0 or the mission planner's) are served.
With ``signing_key`` it signs what it sends (MAVLink 2 signing, link id 0) and ignores anything not
validly signed with that key, as an autopilot with signing enabled does.
"""

from __future__ import annotations

import logging
import math
import socket
import threading
import time
from typing import Callable

from uvteam.autopilot import MissionItem, VehicleState, mavlink2
from uvteam.io.mavlink import DatagramParser, signing_timestamp

__all__ = ["SimAutopilot"]

log = logging.getLogger(__name__)

_GLOBAL_FRAMES = frozenset({mavlink2.MAV_FRAME_GLOBAL, mavlink2.MAV_FRAME_GLOBAL_RELATIVE_ALT,
                            mavlink2.MAV_FRAME_GLOBAL_INT, mavlink2.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT})
_AP_LOCATION_FRAMES = _GLOBAL_FRAMES | {mavlink2.MAV_FRAME_MISSION, mavlink2.MAV_FRAME_GLOBAL_TERRAIN_ALT,
                                        mavlink2.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT}
_KNOWN_COMMANDS = frozenset({mavlink2.MAV_CMD_NAV_WAYPOINT, mavlink2.MAV_CMD_DO_CHANGE_SPEED})
_INVALID_PARAM = (mavlink2.MAV_MISSION_INVALID_PARAM1, mavlink2.MAV_MISSION_INVALID_PARAM2,
                  mavlink2.MAV_MISSION_INVALID_PARAM3, mavlink2.MAV_MISSION_INVALID_PARAM4)


def check_item_ardupilot(m) -> int:
    """MAV_MISSION_RESULT of ArduPilot's AP_Mission::mavlink_int_to_mission_cmd for our commands."""
    if m.command not in _KNOWN_COMMANDS:
        return mavlink2.MAV_MISSION_UNSUPPORTED
    nan_ok = {3} if m.command == mavlink2.MAV_CMD_NAV_WAYPOINT else set()   # param4 (yaw) may be NaN
    for k, v in enumerate((m.param1, m.param2, m.param3, m.param4)):
        if math.isinf(v) or (math.isnan(v) and k not in nan_ok):
            return _INVALID_PARAM[k]
    if m.command == mavlink2.MAV_CMD_NAV_WAYPOINT:              # stored with a location
        lat, lon = _latlon_deg(m)
        if not -90 <= lat <= 90:
            return mavlink2.MAV_MISSION_INVALID_PARAM5_X
        if not -180 <= lon <= 180:
            return mavlink2.MAV_MISSION_INVALID_PARAM6_Y
        if math.isnan(m.z) or abs(m.z) >= 83000:                # LOCATION_ALT_MAX_M
            return mavlink2.MAV_MISSION_INVALID_PARAM7
        if m.frame not in _AP_LOCATION_FRAMES:
            return mavlink2.MAV_MISSION_UNSUPPORTED_FRAME
    return mavlink2.MAV_MISSION_ACCEPTED


def check_item_px4(m) -> int:
    """MAV_MISSION_RESULT of PX4's MavlinkMissionManager::parse_mavlink_mission_item for our commands."""
    if m.frame in _GLOBAL_FRAMES:
        ok = m.command == mavlink2.MAV_CMD_NAV_WAYPOINT
    elif m.frame == mavlink2.MAV_FRAME_MISSION:
        ok = m.command == mavlink2.MAV_CMD_DO_CHANGE_SPEED
    else:
        return mavlink2.MAV_MISSION_UNSUPPORTED_FRAME
    return mavlink2.MAV_MISSION_ACCEPTED if ok else mavlink2.MAV_MISSION_UNSUPPORTED


def _latlon_deg(m) -> tuple[float, float]:
    if m.get_type() == "MISSION_ITEM_INT":
        return m.x * 1e-7, m.y * 1e-7
    return float(m.x), float(m.y)


class SimAutopilot:
    def __init__(self, out_host: str, out_port: int, system_id: int, *, boot_unix_s: float,
                 mav_type: int = mavlink2.MAV_TYPE_GROUND_ROVER,
                 autopilot: int = mavlink2.MAV_AUTOPILOT_ARDUPILOTMEGA,
                 on_mission: Callable[[list[MissionItem]], None] | None = None,
                 signing_key: bytes | None = None) -> None:
        if autopilot not in (mavlink2.MAV_AUTOPILOT_ARDUPILOTMEGA, mavlink2.MAV_AUTOPILOT_PX4):
            raise ValueError(f"autopilot: MAV_AUTOPILOT_ARDUPILOTMEGA (3) or MAV_AUTOPILOT_PX4 (12), got {autopilot}")
        self.peer = (out_host, out_port)
        self.system_id = system_id
        self.component_id = mavlink2.MAV_COMP_ID_AUTOPILOT1
        self.boot_unix_s = boot_unix_s
        self.mav_type = mav_type
        self.autopilot = autopilot
        self.ardupilot = autopilot == mavlink2.MAV_AUTOPILOT_ARDUPILOTMEGA
        self.on_mission = on_mission
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.settimeout(0.05)
        self.mav = mavlink2.MAVLink(self, system_id, self.component_id)
        self.parser = DatagramParser(signing_key)   # with a key: only validly signed packets come out
        self.signing_key = signing_key
        if signing_key is not None:
            self.mav.signing.secret_key = signing_key
            self.mav.signing.sign_outgoing = True
            self.mav.signing.timestamp = signing_timestamp()
        self.mission: list[MissionItem] = []        # the mission as it runs (ArduPilot: without HOME)
        self.home: tuple[float, float, float] = (0.0, 0.0, 0.0)   # lat, lon, alt AMSL; set by the first position
        self.current_seq = -1                        # the item the mission starts from / is executing
        self.speed_m_s: float | None = None         # from MAV_CMD_DO_CHANGE_SPEED
        self.rejected: list[tuple[int, int]] = []   # (seq, MAV_MISSION_RESULT) of refused items
        self.commands: list[tuple[int, int]] = []   # (command, MAV_RESULT) answered
        self._upload: dict | None = None
        self._telemetry: dict[int, object] = {}     # the last GLOBAL_POSITION_INT / GPS_RAW_INT / ATTITUDE
        self._home_set = False
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._silent = threading.Event()   # a dead vehicle: sends nothing
        self._thread = threading.Thread(target=self._run, name=f"sim-ap-{system_id}", daemon=True)
        self.missions_received = 0

    # file-like for pymavlink
    def write(self, data: bytes) -> None:
        if self._silent.is_set():
            return
        try:
            self.sock.sendto(data, self.peer)
        except OSError:
            pass

    def _send(self, msg) -> None:
        with self._lock:
            if self.signing_key is not None:
                self.mav.signing.timestamp = max(self.mav.signing.timestamp, signing_timestamp())
            self.mav.send(msg)

    def start(self) -> "SimAutopilot":
        self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        self._thread.join(timeout=2.0)
        self.sock.close()

    def go_silent(self) -> None:
        self._silent.set()

    def boot_ms(self, unix_s: float) -> int:
        return max(int((unix_s - self.boot_unix_s) * 1000), 0)

    # --- telemetry ---------------------------------------------------------------------------------
    def send_position(self, capture_unix_s: float, lat_deg: float, lon_deg: float, alt_amsl_m: float,
                      alt_rel_m: float, heading_deg: float | None, v_east_m_s: float, v_north_m_s: float,
                      h_acc_m: float, roll_deg: float = 0.0, pitch_deg: float = 0.0,
                      fix_type: int = mavlink2.GPS_FIX_TYPE_3D_FIX) -> None:
        tb = self.boot_ms(capture_unix_s)
        if not self._home_set:
            self.home, self._home_set = (lat_deg, lon_deg, alt_amsl_m), True
        hdg = 65535 if heading_deg is None else int(round(heading_deg * 100)) % 36000
        yaw = math.radians(heading_deg if heading_deg is not None else 0.0)
        msgs = (
            mavlink2.MAVLink_global_position_int_message(
                tb, int(round(lat_deg * 1e7)), int(round(lon_deg * 1e7)), int(round(alt_amsl_m * 1000)),
                int(round(alt_rel_m * 1000)), int(round(v_north_m_s * 100)), int(round(v_east_m_s * 100)), 0, hdg),
            mavlink2.MAVLink_gps_raw_int_message(
                tb * 1000, fix_type, int(round(lat_deg * 1e7)), int(round(lon_deg * 1e7)),
                int(round(alt_amsl_m * 1000)), 80, 120, int(round(math.hypot(v_east_m_s, v_north_m_s) * 100)),
                hdg, 12, 0, max(int(round(h_acc_m * 1000)), 1), 2000, 50, 0, 0),
            mavlink2.MAVLink_attitude_message(tb, math.radians(roll_deg), math.radians(pitch_deg),
                                              (yaw + math.pi) % (2 * math.pi) - math.pi, 0.0, 0.0, 0.0),
        )
        for m in msgs:
            self._telemetry[m.get_msgId()] = m
            self._send(m)

    def _heartbeat(self):
        return mavlink2.MAVLink_heartbeat_message(self.mav_type, self.autopilot, mavlink2.MAV_MODE_FLAG_AUTO_ENABLED,
                                                  0, mavlink2.MAV_STATE_ACTIVE, 3)

    def _system_time(self):
        t = time.time()
        return mavlink2.MAVLink_system_time_message(int(t * 1e6), self.boot_ms(t))

    def send_state(self, st: VehicleState) -> None:
        """A vehicle state as the autopilot streams it (capture time, position, heading, velocity, accuracy)."""
        self.send_position(st.stamp_s, st.lat_deg, st.lon_deg, st.alt_amsl_m, st.alt_agl_m, st.heading_deg,
                           st.v_east_m_s, st.v_north_m_s, st.h_acc_m if st.h_acc_m is not None else 5.0,
                           st.roll_deg or 0.0, st.pitch_deg or 0.0,
                           mavlink2.GPS_FIX_TYPE_3D_FIX if st.fix_type is None else st.fix_type)

    # --- loop --------------------------------------------------------------------------------------
    def _run(self) -> None:
        next_hb = 0.0
        while not self._stop.is_set():
            now = time.monotonic()
            if now >= next_hb:
                self._send(self._heartbeat())
                self._send(self._system_time())
                next_hb = now + 1.0
            self._upload_tick(now)
            try:
                data, _ = self.sock.recvfrom(65535)
            except (socket.timeout, BlockingIOError):
                continue
            except OSError:
                return
            if self._silent.is_set():
                continue
            for m in self.parser.parse(data):
                try:
                    self._handle(m)
                except Exception:  # a malformed request must not stop the vehicle
                    log.exception("sim autopilot %d: bad request %s", self.system_id, m.get_type())

    def _for_me(self, m) -> bool:
        return (getattr(m, "target_system", self.system_id) == self.system_id
                and getattr(m, "target_component", 0) in (0, self.component_id, mavlink2.MAV_COMP_ID_MISSIONPLANNER))

    def _handle(self, m) -> None:
        t = m.get_type()
        if not self._for_me(m):
            return
        if t == "COMMAND_LONG":
            self._command(m)
            return
        if not t.startswith("MISSION_"):
            return
        if getattr(m, "mission_type", 0) not in (0, None):
            self._send(mavlink2.MAVLink_mission_ack_message(m.get_srcSystem(), m.get_srcComponent(),
                                                            mavlink2.MAV_MISSION_UNSUPPORTED, m.mission_type))
            return
        src = (m.get_srcSystem(), m.get_srcComponent())
        if t == "MISSION_REQUEST_LIST":
            self._send(mavlink2.MAVLink_mission_count_message(*src, len(self._stored()), 0))
        elif t in ("MISSION_REQUEST_INT", "MISSION_REQUEST"):
            if self._upload is None:
                stored = self._stored()
                if 0 <= m.seq < len(stored):
                    self._send(stored[m.seq].to_msg(m.seq, *src))
                else:
                    self._send(mavlink2.MAVLink_mission_ack_message(*src, mavlink2.MAV_MISSION_INVALID_SEQUENCE, 0))
        elif t == "MISSION_COUNT":
            if m.count > 1000:
                self._send(mavlink2.MAVLink_mission_ack_message(*src, mavlink2.MAV_MISSION_NO_SPACE, 0))
                return
            self._upload = {"src": src, "count": m.count, "items": [], "asked": 0.0, "tries": 0}
            if m.count == 0:
                self._finish_upload()
            else:
                self._request_next(time.monotonic())
        elif t in ("MISSION_ITEM_INT", "MISSION_ITEM") and self._upload is not None:
            self._on_item(m)
        elif t == "MISSION_CLEAR_ALL":
            self.mission, self.current_seq = [], -1
            self._send(mavlink2.MAVLink_mission_ack_message(*src, mavlink2.MAV_MISSION_ACCEPTED, 0))
            if self.on_mission:
                self.on_mission([])

    def _stored(self) -> list[MissionItem]:
        """The mission as a download shows it: HOME first on ArduPilot; ``current`` on the current item."""
        items = list(self.mission)
        if self.ardupilot:
            lat, lon, alt = self.home
            items = [MissionItem(mavlink2.MAV_CMD_NAV_WAYPOINT, lat, lon, alt, frame=mavlink2.MAV_FRAME_GLOBAL)] + items
        return [MissionItem(it.command, it.lat_deg, it.lon_deg, it.alt_m, it.param1, it.param2, it.param3,
                            it.param4, it.frame, it.autocontinue, int(k == self.current_seq))
                for k, it in enumerate(items)]

    def _on_item(self, m) -> None:
        up = self._upload
        if m.seq != len(up["items"]):
            return                                    # not the expected item: ignore (both stacks do)
        home_slot = self.ardupilot and m.seq == 0     # ArduPilot keeps HOME at 0 whatever comes there
        result = mavlink2.MAV_MISSION_ACCEPTED
        if not home_slot:
            result = check_item_ardupilot(m) if self.ardupilot else check_item_px4(m)
        if result != mavlink2.MAV_MISSION_ACCEPTED:
            self.rejected.append((m.seq, result))
            self._upload = None
            self._send(mavlink2.MAVLink_mission_ack_message(*up["src"], result, 0))
            return
        up["items"].append(MissionItem.from_msg(m))
        up["tries"] = 0
        if len(up["items"]) == up["count"]:
            self._finish_upload()
        else:
            self._request_next(time.monotonic())

    def _request_next(self, now: float) -> None:
        up = self._upload
        up["asked"] = now
        self._send(mavlink2.MAVLink_mission_request_int_message(*up["src"], len(up["items"]), 0))

    def _upload_tick(self, now: float) -> None:
        up = self._upload
        if up is None or now - up["asked"] < 0.25:
            return
        up["tries"] += 1
        if up["tries"] > 8:
            self._send(mavlink2.MAVLink_mission_ack_message(*up["src"], mavlink2.MAV_MISSION_OPERATION_CANCELLED, 0))
            self._upload = None
            return
        self._request_next(now)

    def _finish_upload(self) -> None:
        up, self._upload = self._upload, None
        items = up["items"]
        if self.ardupilot:        # HOME stays; the mission restarts at its first real command (index 1)
            self.mission, self.current_seq = items[1:], 1 if len(items) > 1 else -1
        else:                     # PX4: the item marked current, -1 when none was
            self.mission = items
            self.current_seq = next((k for k, it in enumerate(items) if it.current), -1)
        self.missions_received += 1
        self._send(mavlink2.MAVLink_mission_ack_message(*up["src"], mavlink2.MAV_MISSION_ACCEPTED, 0))
        if self.on_mission:
            self.on_mission(list(self.mission))

    # --- commands ----------------------------------------------------------------------------------
    def _command(self, m) -> None:
        follow = None
        if m.command == mavlink2.MAV_CMD_DO_CHANGE_SPEED:
            ok = math.isfinite(m.param2)
            if ok and m.param2 > 0:
                self.speed_m_s = float(m.param2)
            result = mavlink2.MAV_RESULT_ACCEPTED if ok else mavlink2.MAV_RESULT_DENIED
        elif m.command == mavlink2.MAV_CMD_REQUEST_MESSAGE:
            follow = self._message_for(m.param1)
            result = mavlink2.MAV_RESULT_ACCEPTED if follow is not None else mavlink2.MAV_RESULT_FAILED
        else:
            result = mavlink2.MAV_RESULT_UNSUPPORTED
        self.commands.append((m.command, result))
        self._send(mavlink2.MAVLink_command_ack_message(m.command, result, 0, 0, m.get_srcSystem(),
                                                        m.get_srcComponent()))
        if follow is not None:
            self._send(follow)

    def _message_for(self, msg_id: float):
        if not math.isfinite(msg_id):
            return None
        mid = int(msg_id)
        if mid == mavlink2.MAVLINK_MSG_ID_HEARTBEAT:
            return self._heartbeat()
        if mid == mavlink2.MAVLINK_MSG_ID_SYSTEM_TIME:
            return self._system_time()
        return self._telemetry.get(mid)
