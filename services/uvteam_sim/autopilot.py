"""A simulated vehicle autopilot speaking MAVLink 2 over UDP, as ArduPilot or PX4 would to a companion.

It streams HEARTBEAT and SYSTEM_TIME (1 Hz), and on request of the simulator GLOBAL_POSITION_INT,
GPS_RAW_INT and ATTITUDE; it serves the mission protocol both ways:

- download: MISSION_REQUEST_LIST -> MISSION_COUNT; MISSION_REQUEST_INT / MISSION_REQUEST(seq) ->
  MISSION_ITEM_INT(seq); the client's MISSION_ACK ends it;
- upload: MISSION_COUNT(n) -> MISSION_REQUEST_INT(0..n-1), re-requested when an item is late ->
  MISSION_ACK(ACCEPTED), and the new mission replaces the old one (``on_mission`` is called).

Only messages addressed to this system (target_system) are served. With ``signing_key`` it signs what it
sends (MAVLink 2 signing, link id 0) and ignores anything not validly signed with that key, as an
autopilot with signing enabled does.
"""

from __future__ import annotations

import logging
import math
import socket
import threading
import time
from typing import Callable

from uvteam.autopilot import MissionItem, mavlink2
from uvteam.io.mavlink import DatagramParser, signing_timestamp

__all__ = ["SimAutopilot"]

log = logging.getLogger(__name__)


class SimAutopilot:
    def __init__(self, out_host: str, out_port: int, system_id: int, *, boot_unix_s: float,
                 mav_type: int = mavlink2.MAV_TYPE_GROUND_ROVER,
                 on_mission: Callable[[list[MissionItem]], None] | None = None,
                 signing_key: bytes | None = None) -> None:
        self.peer = (out_host, out_port)
        self.system_id = system_id
        self.boot_unix_s = boot_unix_s
        self.mav_type = mav_type
        self.on_mission = on_mission
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.settimeout(0.05)
        self.mav = mavlink2.MAVLink(self, system_id, mavlink2.MAV_COMP_ID_AUTOPILOT1)
        self.parser = DatagramParser(signing_key)   # with a key: only validly signed packets come out
        self.signing_key = signing_key
        if signing_key is not None:
            self.mav.signing.secret_key = signing_key
            self.mav.signing.sign_outgoing = True
            self.mav.signing.timestamp = signing_timestamp()
        self.mission: list[MissionItem] = []
        self._upload: dict | None = None
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
        hdg = 65535 if heading_deg is None else int(round(heading_deg * 100)) % 36000
        self._send(mavlink2.MAVLink_global_position_int_message(
            tb, int(round(lat_deg * 1e7)), int(round(lon_deg * 1e7)), int(round(alt_amsl_m * 1000)),
            int(round(alt_rel_m * 1000)), int(round(v_north_m_s * 100)), int(round(v_east_m_s * 100)), 0, hdg))
        self._send(mavlink2.MAVLink_gps_raw_int_message(
            tb * 1000, fix_type, int(round(lat_deg * 1e7)), int(round(lon_deg * 1e7)), int(round(alt_amsl_m * 1000)),
            80, 120, int(round(math.hypot(v_east_m_s, v_north_m_s) * 100)), hdg if hdg != 65535 else 65535, 12,
            0, max(int(round(h_acc_m * 1000)), 1), 2000, 50, 0, 0))
        yaw = math.radians(heading_deg if heading_deg is not None else 0.0)
        self._send(mavlink2.MAVLink_attitude_message(tb, math.radians(roll_deg), math.radians(pitch_deg),
                                                     (yaw + math.pi) % (2 * math.pi) - math.pi, 0.0, 0.0, 0.0))

    # --- loop --------------------------------------------------------------------------------------
    def _run(self) -> None:
        next_hb = 0.0
        while not self._stop.is_set():
            now = time.monotonic()
            if now >= next_hb:
                self._send(mavlink2.MAVLink_heartbeat_message(
                    self.mav_type, mavlink2.MAV_AUTOPILOT_ARDUPILOTMEGA, mavlink2.MAV_MODE_FLAG_AUTO_ENABLED,
                    0, mavlink2.MAV_STATE_ACTIVE, 3))
                t = time.time()
                self._send(mavlink2.MAVLink_system_time_message(int(t * 1e6), self.boot_ms(t)))
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
        return getattr(m, "target_system", self.system_id) == self.system_id

    def _handle(self, m) -> None:
        t = m.get_type()
        if not t.startswith("MISSION_") or not self._for_me(m):
            return
        if getattr(m, "mission_type", 0) not in (0, None):
            self._send(mavlink2.MAVLink_mission_ack_message(m.get_srcSystem(), m.get_srcComponent(),
                                                            mavlink2.MAV_MISSION_UNSUPPORTED, m.mission_type))
            return
        src = (m.get_srcSystem(), m.get_srcComponent())
        if t == "MISSION_REQUEST_LIST":
            self._send(mavlink2.MAVLink_mission_count_message(*src, len(self.mission), 0))
        elif t in ("MISSION_REQUEST_INT", "MISSION_REQUEST"):
            if self._upload is None:
                if 0 <= m.seq < len(self.mission):
                    self._send(self.mission[m.seq].to_msg(m.seq, *src))
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
            up = self._upload
            if m.seq == len(up["items"]):
                up["items"].append(MissionItem.from_msg(m))
                up["tries"] = 0
                if len(up["items"]) == up["count"]:
                    self._finish_upload()
                else:
                    self._request_next(time.monotonic())
        elif t == "MISSION_CLEAR_ALL":
            self.mission = []
            self._send(mavlink2.MAVLink_mission_ack_message(*src, mavlink2.MAV_MISSION_ACCEPTED, 0))
            if self.on_mission:
                self.on_mission([])

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
        self.mission = up["items"]
        self.missions_received += 1
        self._send(mavlink2.MAVLink_mission_ack_message(*up["src"], mavlink2.MAV_MISSION_ACCEPTED, 0))
        if self.on_mission:
            self.on_mission(list(self.mission))
