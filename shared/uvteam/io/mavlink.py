"""MAVLink 2 link to a vehicle's autopilot (ArduPilot, PX4, or the simulator): state in, missions both ways.

    link = AutopilotLink("udpin:0.0.0.0:14550", target_system=1)
    link.start()
    state = link.state()                 # latest VehicleState in SI units, or None
    items = link.download_mission()      # MISSION_REQUEST_LIST -> COUNT -> REQUEST_INT(seq) -> ITEM_INT -> ACK
    link.upload_mission(items)           # COUNT -> (vehicle) REQUEST_INT(seq) -> ITEM_INT ... -> (vehicle) ACK

URLs: ``udpin:HOST:PORT`` (listen; the autopilot sends first, as autopilots stream to their companion),
``udpout:HOST:PORT`` (send to the autopilot; heartbeats open the path), ``tcp:HOST:PORT`` and serial
``/dev/ttyX:BAUD`` through pymavlink's mavutil.

Robustness: only messages from ``target_system``/``target_component`` (component 0 = any) are used;
BAD_DATA and unknown messages are dropped and counted; every value is range-checked after unit
conversion; on UDP each datagram is parsed on its own (the parser is reset afterwards), because a
truncated datagram otherwise swallows the next good packets (pymavlink is pinned for this reason).
The link is "up" while a HEARTBEAT from the target arrived within ``link_timeout_s``; TCP and serial
links are reopened after errors. Optional MAVLink 2 signing with a 32-byte key.

Time: GLOBAL_POSITION_INT carries the autopilot's boot time; SYSTEM_TIME gives the offset to UNIX time,
so a fix's ``stamp_s`` is its capture time, not its arrival time (arrival time is used, and said so in
``VehicleState.stamp_source``, until SYSTEM_TIME has been seen).
"""

from __future__ import annotations

import logging
import math
import queue
import socket
import threading
import time
from dataclasses import replace

from ..autopilot import MissionItem, VehicleState, mavlink2
from ..errors import LinkError

__all__ = ["AutopilotLink", "DatagramParser", "parse_url"]

log = logging.getLogger(__name__)


DEFAULT_BAUD = 57600


def parse_url(url: str) -> tuple[str, str, int]:
    """'udpin:HOST:PORT' -> ('udpin', HOST, PORT); also udpout, tcp; anything else is a serial device,
    'DEVICE:BAUD' -> ('serial', DEVICE, BAUD) (BAUD 57600 when left out)."""
    kind, _, rest = url.partition(":")
    if kind in ("udpin", "udpout", "udp", "tcp"):
        host, _, port = rest.rpartition(":")
        try:
            p = int(port)
        except ValueError:
            raise LinkError(url, "expected KIND:HOST:PORT") from None
        if not (0 < p < 65536) or not host:
            raise LinkError(url, "expected KIND:HOST:PORT with a port in 1-65535")
        return ("udpin" if kind == "udp" else kind), host, p
    dev, sep, baud = url.rpartition(":")
    if not sep:
        return "serial", url, DEFAULT_BAUD
    try:
        b = int(baud)
    except ValueError:
        raise LinkError(url, "expected a serial device as DEVICE:BAUD, e.g. /dev/ttyACM0:57600") from None
    if b <= 0 or not dev:
        raise LinkError(url, "expected a serial device as DEVICE:BAUD with a positive baud rate")
    return "serial", dev, b


class DatagramParser:
    """A MAVLink 2 parser that forgets everything between datagrams (see module docstring)."""

    def __init__(self, mav: mavlink2.MAVLink) -> None:
        self.mav = mav
        self.bad = 0

    def parse(self, data: bytes) -> list:
        out = []
        try:
            msgs = self.mav.parse_buffer(data) or []
        except mavlink2.MAVError:
            msgs = []
            self.bad += 1
        for m in msgs:
            if m.get_type() == "BAD_DATA" or m.get_type().startswith("UNKNOWN"):
                self.bad += 1
            else:
                out.append(m)
        mav = self.mav  # reset: private attributes of pymavlink 2.4.50 (pinned, tested)
        mav.buf = bytearray()
        mav.buf_index = 0
        mav.expected_length = mavlink2.HEADER_LEN_V1 + 2
        mav.have_prefix_error = False
        return out


class _UdpTransport:
    def __init__(self, kind: str, host: str, port: int) -> None:
        self.kind = kind
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.settimeout(0.1)
        self.peer: tuple[str, int] | None = None
        if kind == "udpin":
            self.sock.bind((host, port))
        else:
            self.peer = (host, port)

    def write(self, data: bytes) -> None:
        if self.peer is not None:
            try:
                self.sock.sendto(data, self.peer)
            except OSError as exc:
                log.debug("udp send failed: %s", exc)

    def recv(self) -> bytes | None:
        try:
            data, addr = self.sock.recvfrom(65535)
        except (socket.timeout, BlockingIOError):
            return None
        except OSError:
            return None
        if self.kind == "udpin":
            self.peer = addr  # reply to whoever the autopilot is (filtered by system id above)
        return data

    def close(self) -> None:
        self.sock.close()


class AutopilotLink:
    def __init__(self, url: str, *, target_system: int = 1, target_component: int = 0,
                 source_system: int = 245, source_component: int = mavlink2.MAV_COMP_ID_ONBOARD_COMPUTER,
                 signing_key: bytes | None = None, link_id: int = 0, link_timeout_s: float = 3.0,
                 heartbeat_hz: float = 1.0) -> None:
        self.url = url
        self.kind, self.host, self.port = parse_url(url)
        self.target_system, self.target_component = target_system, target_component
        self.source_system, self.source_component = source_system, source_component
        self.signing_key, self.link_id = signing_key, link_id
        if signing_key is not None and len(signing_key) != 32:
            raise LinkError(url, f"a MAVLink 2 signing key has 32 bytes, got {len(signing_key)}")
        self.link_timeout_s, self.heartbeat_period_s = link_timeout_s, 1.0 / heartbeat_hz
        self._lock = threading.Lock()
        self._state: VehicleState | None = None
        self._h_acc: float | None = None
        self._att: tuple[float, float, float] | None = None
        self._boot_offset_s: float | None = None
        self._last_hb = -math.inf
        self._mission_q: queue.Queue = queue.Queue()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._tx_lock = threading.Lock()
        self.counters = {"received": 0, "ignored_source": 0, "bad": 0, "out_of_range": 0, "reconnects": 0}
        self._transport = None
        self._mav: mavlink2.MAVLink | None = None
        self._conn = None  # mavutil connection for tcp/serial

    # --- lifecycle -------------------------------------------------------------------------------
    def start(self) -> "AutopilotLink":
        self._open()
        self._thread = threading.Thread(target=self._run, name=f"mavlink:{self.url}", daemon=True)
        self._thread.start()
        return self

    def close(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
        if self._transport is not None:
            self._transport.close()
        if self._conn is not None:
            try:
                self._conn.close()
            except OSError:
                pass

    def __enter__(self) -> "AutopilotLink":
        return self.start()

    def __exit__(self, *exc) -> None:
        self.close()

    def _open(self) -> None:
        if self.kind in ("udpin", "udpout"):
            self._transport = _UdpTransport(self.kind, self.host, self.port)
            self._mav = mavlink2.MAVLink(self._transport, self.source_system, self.source_component)
        else:
            from pymavlink import mavutil  # noqa: PLC0415

            dev = f"tcp:{self.host}:{self.port}" if self.kind == "tcp" else self.host
            extra = {"baud": self.port} if self.kind == "serial" else {}
            try:
                self._conn = mavutil.mavlink_connection(dev, source_system=self.source_system, **extra,
                                                        source_component=self.source_component,
                                                        autoreconnect=True, dialect="ardupilotmega")
            except (OSError, ConnectionError) as exc:
                raise LinkError(self.url, str(exc)) from None
            self._mav = self._conn.mav
        if self.signing_key is not None:
            self._mav.signing.secret_key = self.signing_key
            self._mav.signing.link_id = self.link_id
            self._mav.signing.sign_outgoing = True
            self._mav.signing.timestamp = int((time.time() - 1420070400) * 1e5)
            self._mav.signing.allow_unsigned_callback = None

    # --- state -----------------------------------------------------------------------------------
    def state(self) -> VehicleState | None:
        with self._lock:
            return self._state

    @property
    def link_up(self) -> bool:
        return time.monotonic() - self._last_hb <= self.link_timeout_s

    @property
    def link_state(self) -> str:
        return "up" if self.link_up else "down"

    # --- I/O loop ----------------------------------------------------------------------------------
    def send(self, msg) -> None:
        with self._tx_lock:
            self._mav.send(msg)

    def _heartbeat(self) -> None:
        self.send(mavlink2.MAVLink_heartbeat_message(
            mavlink2.MAV_TYPE_ONBOARD_CONTROLLER, mavlink2.MAV_AUTOPILOT_INVALID, 0, 0, mavlink2.MAV_STATE_ACTIVE, 3))

    def _run(self) -> None:
        parser = DatagramParser(self._mav) if self._transport is not None else None
        next_hb = 0.0
        while not self._stop.is_set():
            now = time.monotonic()
            if now >= next_hb:
                try:
                    self._heartbeat()
                except (OSError, ConnectionError):
                    pass
                next_hb = now + self.heartbeat_period_s
            if parser is not None:
                data = self._transport.recv()
                if data is None:
                    continue
                msgs = parser.parse(data)
                self.counters["bad"] = parser.bad
            else:
                try:
                    m = self._conn.recv_match(blocking=True, timeout=0.1)
                except (OSError, ConnectionError) as exc:
                    self.counters["reconnects"] += 1
                    log.warning("autopilot link %s: %s; retrying", self.url, exc)
                    self._stop.wait(0.5)
                    continue
                if m is None:
                    continue
                if m.get_type() == "BAD_DATA" or m.get_type().startswith("UNKNOWN"):
                    self.counters["bad"] += 1
                    continue
                msgs = [m]
            for m in msgs:
                self._handle(m)

    def _from_target(self, m) -> bool:
        if m.get_srcSystem() != self.target_system:
            return False
        return self.target_component == 0 or m.get_srcComponent() == self.target_component

    def _handle(self, m) -> None:
        if not self._from_target(m):
            self.counters["ignored_source"] += 1
            return
        self.counters["received"] += 1
        t = m.get_type()
        if t == "HEARTBEAT":
            self._last_hb = time.monotonic()
        elif t == "SYSTEM_TIME":
            if m.time_unix_usec > 1_000_000_000 * 1_000_000:  # a real clock (after 2001)
                self._boot_offset_s = m.time_unix_usec * 1e-6 - m.time_boot_ms * 1e-3
        elif t == "GPS_RAW_INT":
            h = getattr(m, "h_acc", 0)  # mm, MAVLink 2 extension; 0 = unknown
            self._h_acc = h / 1000.0 if h and h < 1_000_000 else None
            with self._lock:  # autopilots send it before or after the position: apply it either way
                if self._state is not None and self._h_acc is not None:
                    self._state = replace(self._state, h_acc_m=self._h_acc)
        elif t == "ATTITUDE":
            vals = (math.degrees(m.roll), math.degrees(m.pitch), math.degrees(m.yaw))
            if all(math.isfinite(v) and abs(v) <= 360.0 for v in vals):
                self._att = vals
            else:
                self.counters["out_of_range"] += 1
        elif t == "GLOBAL_POSITION_INT":
            self._on_position(m)
        elif t.startswith("MISSION_"):
            self._mission_q.put(m)

    def _on_position(self, m) -> None:
        lat, lon = m.lat * 1e-7, m.lon * 1e-7
        alt_amsl, alt_rel = m.alt / 1000.0, m.relative_alt / 1000.0
        heading = None if m.hdg == 65535 else m.hdg / 100.0
        ve, vn = m.vy / 100.0, m.vx / 100.0  # NED cm/s -> east/north m/s
        ok = (-90 <= lat <= 90 and -180 <= lon <= 180 and -500 <= alt_amsl <= 12000
              and (heading is None or 0 <= heading < 360) and abs(ve) < 150 and abs(vn) < 150
              and not (lat == 0 and lon == 0))
        if not ok:
            self.counters["out_of_range"] += 1
            return
        if self._boot_offset_s is not None:
            stamp, src = self._boot_offset_s + m.time_boot_ms * 1e-3, "autopilot"
        else:
            stamp, src = time.time(), "arrival"
        att = self._att
        st = VehicleState(stamp, src, lat, lon, alt_amsl, alt_rel, heading, ve, vn, self._h_acc,
                          *(att if att else (None, None, None)))
        with self._lock:
            self._state = st

    # --- mission protocol ----------------------------------------------------------------------------
    def _drain_mission(self) -> None:
        while True:
            try:
                self._mission_q.get_nowait()
            except queue.Empty:
                return

    def _await(self, types: tuple[str, ...], timeout_s: float, seq: int | None = None):
        deadline = time.monotonic() + timeout_s
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                return None
            try:
                m = self._mission_q.get(timeout=left)
            except queue.Empty:
                return None
            if m.get_type() in types and (seq is None or getattr(m, "seq", seq) == seq):
                if getattr(m, "mission_type", 0) not in (0, None):
                    continue
                return m

    def download_mission(self, *, timeout_s: float = 0.5, retries: int = 5) -> list[MissionItem]:
        """The vehicle's mission items (plain mission type), or LinkError."""
        ts, tc = self.target_system, max(self.target_component, 1)
        self._drain_mission()
        count_msg = None
        for _ in range(retries):
            self.send(mavlink2.MAVLink_mission_request_list_message(ts, tc, mavlink2.MAV_MISSION_TYPE_MISSION))
            count_msg = self._await(("MISSION_COUNT",), timeout_s)
            if count_msg is not None:
                break
        if count_msg is None:
            raise LinkError(self.url, "no MISSION_COUNT in reply to MISSION_REQUEST_LIST")
        items: list[MissionItem] = []
        for seq in range(count_msg.count):
            got = None
            for _ in range(retries):
                self.send(mavlink2.MAVLink_mission_request_int_message(ts, tc, seq, mavlink2.MAV_MISSION_TYPE_MISSION))
                got = self._await(("MISSION_ITEM_INT", "MISSION_ITEM"), timeout_s, seq)
                if got is not None:
                    break
            if got is None:
                raise LinkError(self.url, f"mission item {seq} did not arrive")
            items.append(MissionItem.from_msg(got))
        self.send(mavlink2.MAVLink_mission_ack_message(ts, tc, mavlink2.MAV_MISSION_ACCEPTED,
                                                       mavlink2.MAV_MISSION_TYPE_MISSION))
        return items

    def upload_mission(self, items: list[MissionItem], *, timeout_s: float = 0.5, retries: int = 5) -> None:
        """Replace the vehicle's mission; LinkError unless the vehicle ACKs it as accepted."""
        ts, tc = self.target_system, max(self.target_component, 1)
        self._drain_mission()
        self.send(mavlink2.MAVLink_mission_count_message(ts, tc, len(items), mavlink2.MAV_MISSION_TYPE_MISSION))
        sent_any = False
        misses = 0
        while True:
            m = self._await(("MISSION_REQUEST_INT", "MISSION_REQUEST", "MISSION_ACK"), timeout_s)
            if m is None:
                misses += 1
                if misses > retries:
                    raise LinkError(self.url, "mission upload timed out")
                if not sent_any:  # the COUNT may have been lost
                    self.send(mavlink2.MAVLink_mission_count_message(ts, tc, len(items),
                                                                     mavlink2.MAV_MISSION_TYPE_MISSION))
                continue
            if m.get_type() == "MISSION_ACK":
                if m.type == mavlink2.MAV_MISSION_ACCEPTED:
                    return
                raise LinkError(self.url, f"mission rejected by the vehicle (MAV_MISSION_RESULT {m.type})")
            if not 0 <= m.seq < len(items):
                raise LinkError(self.url, f"vehicle asked for item {m.seq} of {len(items)}")
            self.send(items[m.seq].to_msg(m.seq, ts, tc))
            sent_any = True
            misses = 0
