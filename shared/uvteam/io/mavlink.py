"""MAVLink 2 link to a vehicle's autopilot (ArduPilot, PX4, or the simulator): state in, missions both ways.

    link = AutopilotLink("udpin:0.0.0.0:14550", target_system=1)
    link.start()
    state = link.state()                 # latest VehicleState in SI units, or None
    items = link.download_mission()      # MISSION_REQUEST_LIST -> COUNT -> REQUEST_INT(seq) -> ITEM_INT -> ACK
    link.upload_mission(items)           # COUNT -> (vehicle) REQUEST_INT(seq) -> ITEM_INT ... -> (vehicle) ACK
    result = link.command_long(mavlink2.MAV_CMD_DO_CHANGE_SPEED, 1, 2.0, -1)   # -> MAV_RESULT of COMMAND_ACK

URLs: ``udpin:HOST:PORT`` (listen; the autopilot sends first, as autopilots stream to their companion),
``udpout:HOST:PORT`` (send to the autopilot; heartbeats open the path), ``tcp:HOST:PORT`` (client,
reconnects) and serial ``/dev/ttyX:BAUD`` (reopened after errors).

What comes in, and what is believed (:class:`MavlinkParser`, :meth:`AutopilotLink.ingest`):

- Framing is ours, on every transport: each start byte's frame is decoded with pymavlink's public
  ``MAVLink.decode`` (CRC with CRC_EXTRA); one that does not decode costs one byte, and the scan resumes
  right after its start byte. So noise before, between or after packets, a truncated packet or a false
  start byte never swallows a valid packet (pymavlink's own parser keeps a partial packet across UDP
  datagrams and lost the next 2-11 good packets). UDP datagrams are parsed one by one (a MAVLink packet
  never spans two); TCP and serial are a stream, where a frame may arrive in pieces.
- Only messages from ``target_system``/``target_component`` (component 0 = any) are used; every value is
  range-checked after unit conversion; mission and command replies must be addressed to us.
- ``udpin``: the reply address is learned only from a datagram that held a valid packet of the target
  (validly signed when signing is on). Anyone else's datagram -- a stray byte, another system, a forged
  signature -- never changes where heartbeats and missions go. Without signing a stranger can still
  spoof the target's system id: that is what signing is for.
- Signing (``signing_key``, 32 bytes): checked by us on UDP, TCP and serial alike, independent of
  pymavlink's ``mavutil`` (which swaps its ``mav`` object, and the key with it, when it meets the first
  MAVLink 2 byte unless MAVLINK20 is set). The HMAC is verified before the packet's timestamp is
  recorded, so a forged packet with a future timestamp cannot lock the genuine stream out (pymavlink
  records it first). Replays (timestamp not newer than the stream's last) and new streams more than one
  minute behind our clock are refused, as the MAVLink 2 signing spec says. What we send is signed with
  a timestamp that follows the wall clock (pymavlink only adds 1 per packet).

The link is "up" while a HEARTBEAT from the target arrived within ``link_timeout_s``.

Time: GLOBAL_POSITION_INT carries the autopilot's boot time; SYSTEM_TIME gives the offset to UNIX time,
so a fix's ``stamp_s`` is its capture time, not its arrival time (arrival time is used, and said so in
``VehicleState.stamp_source``, until SYSTEM_TIME has been seen).

Missions and the autopilot's conventions (read in their sources, 2026-12): ArduPilot keeps HOME as item 0
(AP_Mission::read_cmd_from_storage returns home for index 0 whatever was uploaded there, and missions run
from index 1, AP_MISSION_FIRST_REAL_COMMAND), ignores ``current`` on upload and reports the running item
as current on download. PX4 (mavlink_mission.cpp) starts the mission at the uploaded item marked
``current``; MAVSDK marks item 0. So :meth:`AutopilotLink.upload_mission` puts a HOME placeholder at seq 0
for ArduPilot (and drops it again on download) and marks the first item current for everyone else; which
stack it is comes from the target's HEARTBEAT.autopilot.
"""

from __future__ import annotations

import hashlib
import hmac
import logging
import math
import queue
import select
import socket
import threading
import time
from dataclasses import replace

from ..autopilot import MissionItem, VehicleState, mavlink2
from ..errors import LinkError

__all__ = ["AutopilotLink", "MavlinkParser", "DatagramParser", "parse_url", "signing_timestamp"]

log = logging.getLogger(__name__)


DEFAULT_BAUD = 57600
WAIT_SLICE_S = 0.1                       # a wait for the autopilot looks at its cancel flag this often
SIGNING_EPOCH_UNIX_S = 1420070400       # MAVLink 2 signing timestamps: 10 us units since 2015-01-01 UTC
NEW_STREAM_MAX_LAG = 60 * 100_000        # a new signed stream may be at most 1 minute behind our clock
_V1, _V2 = mavlink2.PROTOCOL_MARKER_V1, mavlink2.PROTOCOL_MARKER_V2
_SIGNED = mavlink2.MAVLINK_IFLAG_SIGNED
_SIG_LEN = mavlink2.MAVLINK_SIGNATURE_BLOCK_LEN
ARDUPILOT = "ardupilot"
STANDARD = "standard"


def signing_timestamp(unix_s: float | None = None) -> int:
    """The MAVLink 2 signing timestamp for a UNIX time (now by default)."""
    return int(((time.time() if unix_s is None else unix_s) - SIGNING_EPOCH_UNIX_S) * 100_000)


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


class MavlinkParser:
    """MAVLink 1 and 2 packets out of bytes: every valid packet kept, nothing else (see module docstring).

    ``datagram=True``: each :meth:`parse` call is one datagram and nothing carries over to the next.
    ``datagram=False``: a byte stream; a frame cut at the end of a chunk waits for the next one. A false
    start byte can then delay (never lose) the packets behind it by up to one frame's length (280 bytes).
    ``signing_key``: only MAVLink 2 packets carrying a valid signature with this key come out.
    Uses only pymavlink's public API: ``MAVLink.decode`` and the dialect's constants.
    """

    MAX_FRAME = mavlink2.HEADER_LEN_V2 + 255 + 2 + _SIG_LEN

    def __init__(self, *, datagram: bool, signing_key: bytes | None = None,
                 clock=time.time) -> None:
        if signing_key is not None and len(signing_key) != 32:
            raise ValueError(f"signing_key: a MAVLink 2 signing key has 32 bytes, got {len(signing_key)}")
        self.datagram = datagram
        self.signing_key = signing_key
        self._clock = clock
        self._decoder = mavlink2.MAVLink(None)     # no key: signatures are checked here, not by pymavlink
        self._tail = bytearray()
        self._streams: dict[tuple[int, int, int], int] = {}
        self._newest = 0                            # newest accepted signing timestamp
        self.counters = {"packets": 0, "noise_bytes": 0, "bad_frames": 0, "unknown": 0,
                         "unsigned": 0, "bad_signature": 0, "replayed": 0, "stale_stream": 0}

    @property
    def bad(self) -> int:
        """Frames refused: CRC or length wrong, unknown message id, or signing."""
        c = self.counters
        return c["bad_frames"] + c["unknown"] + c["unsigned"] + c["bad_signature"] + c["replayed"] + c["stale_stream"]

    def parse(self, data: bytes) -> list:
        """The messages in ``data`` (one datagram, or the next chunk of a stream), in order."""
        buf = self._tail + data if not self.datagram else bytearray(data)
        out: list = []
        i, n = 0, len(buf)
        while i < n:
            j = self._next_start(buf, i)
            self.counters["noise_bytes"] += j - i
            i = j
            if i >= n:
                break
            if n - i < 3:                           # the header's length and flags are not here yet
                if not self.datagram:
                    break
                self.counters["noise_bytes"] += n - i
                i = n
                break
            total = self._frame_length(buf, i)
            if total is None:                       # an incompatibility flag we do not know
                self.counters["bad_frames"] += 1
                i += 1
                continue
            if n - i < total:
                if not self.datagram:
                    break                           # wait for the rest of the frame
                self.counters["bad_frames"] += 1    # a datagram ends inside it: not a packet
                i += 1
                continue
            frame = bytes(buf[i:i + total])
            m = self._decode(frame)
            if m is None:
                i += 1                              # resync right after this start byte
                continue
            signed = frame[0] == _V2 and frame[2] & _SIGNED
            if self.signing_key is None:
                # the CRC does not cover the signature block: unverified, it may be the next packet's
                # first bytes (a signed packet cut right after its CRC), so scan it again
                i += total - (_SIG_LEN if signed else 0)
            else:
                verdict = self._signature(frame, m)
                if verdict in ("bad_signature", "unsigned"):
                    # same reason: resync inside the "signature"; and a frame with no signature vouches for
                    # no more than its CRC, which noise matches now and then, swallowing the packet behind it
                    i += 1
                    continue
                i += total
                if verdict != "ok":
                    continue
            self.counters["packets"] += 1
            out.append(m)
        self._tail = bytearray() if self.datagram else buf[i:]
        return out

    @staticmethod
    def _next_start(buf: bytearray, i: int) -> int:
        a, b = buf.find(_V2, i), buf.find(_V1, i)
        if a < 0:
            return b if b >= 0 else len(buf)
        return a if b < 0 else min(a, b)

    @staticmethod
    def _frame_length(buf: bytearray, i: int) -> int | None:
        plen = buf[i + 1]
        if buf[i] == _V1:
            return mavlink2.HEADER_LEN_V1 + plen + 2
        flags = buf[i + 2]
        if flags & ~_SIGNED:                        # unknown incompatibility flag: the spec says drop
            return None
        return mavlink2.HEADER_LEN_V2 + plen + 2 + (_SIG_LEN if flags & _SIGNED else 0)

    def _decode(self, frame: bytes):
        try:
            m = self._decoder.decode(bytearray(frame))
        except mavlink2.MAVError:
            self.counters["bad_frames"] += 1
            return None
        if isinstance(m, mavlink2.MAVLink_unknown):  # no CRC_EXTRA: its checksum cannot be checked
            self.counters["unknown"] += 1
            return None
        return m

    def _signature(self, frame: bytes, m) -> str:
        """"ok", or why not (the counter it went to)."""
        verdict = self._verdict(frame, m)
        if verdict != "ok":
            self.counters[verdict] += 1
        return verdict

    def _verdict(self, frame: bytes, m) -> str:
        if frame[0] != _V2 or not frame[2] & _SIGNED:
            return "unsigned"
        want = hashlib.sha256(self.signing_key + frame[:-6]).digest()[:6]
        if not hmac.compare_digest(want, frame[-6:]):
            return "bad_signature"
        stamp = int.from_bytes(frame[-12:-6], "little")
        stream = (frame[-13], m.get_srcSystem(), m.get_srcComponent())
        last = self._streams.get(stream)
        if last is not None and stamp <= last:
            return "replayed"
        if last is None and stamp + NEW_STREAM_MAX_LAG < max(signing_timestamp(self._clock()), self._newest):
            return "stale_stream"
        self._streams[stream] = stamp
        self._newest = max(self._newest, stamp)
        return "ok"


class DatagramParser(MavlinkParser):
    """A :class:`MavlinkParser` for UDP: each datagram on its own."""

    def __init__(self, signing_key: bytes | None = None, *, clock=time.time) -> None:
        super().__init__(datagram=True, signing_key=signing_key, clock=clock)


# --- transports: recv() -> (bytes, source address) | None within ~0.1 s; write(bytes, address) ----------
class _UdpTransport:
    datagram = True

    def __init__(self, kind: str, host: str, port: int) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.settimeout(0.1)
        if kind == "udpin":
            self.sock.bind((host, port))

    def write(self, data: bytes, addr) -> None:
        if addr is None:
            return                                  # udpin: nobody to talk to until the target spoke
        try:
            self.sock.sendto(data, addr)
        except OSError as exc:
            log.debug("udp send failed: %s", exc)

    def recv(self):
        try:
            return self.sock.recvfrom(65535)
        except (socket.timeout, BlockingIOError):
            return None
        except OSError:
            return None

    def close(self) -> None:
        self.sock.close()


class _StreamTransport:
    """TCP client or serial port; reopened after an error or EOF (counted in ``reconnects``)."""

    datagram = False
    RETRY_S = 0.5

    def __init__(self, url: str, kind: str, host: str, port: int) -> None:
        self.url, self.kind, self.host, self.port = url, kind, host, port
        self.reconnects = 0
        self._dev = None
        self._lock = threading.Lock()
        self._next_try = 0.0
        self._open()                                # the first open must work: LinkError otherwise

    def _open(self) -> None:
        try:
            if self.kind == "tcp":
                s = socket.create_connection((self.host, self.port), timeout=2.0)
                s.settimeout(0.1)
                s.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
                self._dev = s
            else:
                import serial  # noqa: PLC0415  (pyserial, only needed for serial links)

                self._dev = serial.Serial(self.host, self.port, timeout=0.1, write_timeout=1.0)
        except (OSError, ValueError) as exc:       # serial.SerialException is an OSError
            raise LinkError(self.url, str(exc)) from None

    def _drop(self, why) -> None:
        log.warning("autopilot link %s: %s; reopening", self.url, why)
        with self._lock:
            dev, self._dev = self._dev, None
        if dev is not None:
            try:
                dev.close()
            except OSError:
                pass
        self._next_try = time.monotonic() + self.RETRY_S

    def recv(self):
        dev = self._dev
        if dev is None:
            if time.monotonic() < self._next_try:
                time.sleep(0.1)
                return None
            try:
                self._open()
                self.reconnects += 1
            except LinkError as exc:
                self._next_try = time.monotonic() + self.RETRY_S
                log.debug("reopen failed: %s", exc)
            return None
        try:
            if self.kind == "tcp":
                data = dev.recv(4096)
                if not data:
                    self._drop("the autopilot closed the TCP connection")
                    return None
            else:
                data = dev.read(max(1, dev.in_waiting))
                if not data:
                    return None
        except (socket.timeout, BlockingIOError):
            return None
        except OSError as exc:
            self._drop(exc)
            return None
        return bytes(data), None

    def write(self, data: bytes, addr=None) -> None:
        with self._lock:
            dev = self._dev
            if dev is None:
                return
            try:
                if self.kind == "tcp":
                    dev.sendall(data)
                else:
                    dev.write(data)
                return
            except (socket.timeout, BlockingIOError):
                return
            except OSError as exc:
                err = exc
        self._drop(err)

    def close(self) -> None:
        with self._lock:
            dev, self._dev = self._dev, None
        if dev is not None:
            try:
                dev.close()
            except OSError:
                pass


class _Sink:
    """The file pymavlink writes packed messages to: the link's transport, to the reply address."""

    def __init__(self, link: "AutopilotLink") -> None:
        self.link = link

    def write(self, data: bytes) -> None:
        t = self.link._transport
        if t is not None:
            t.write(data, self.link.reply_addr)


class AutopilotLink:
    """The companion's end of the link to one autopilot (see the module docstring).

    ``target_system``/``target_component`` (0 = any component): whose messages are used.
    ``source_system``/``source_component``: who we are (replies must be addressed to us).
    ``signing_key`` (32 bytes) and ``link_id``: MAVLink 2 signing, both ways, on every transport.
    ``link_timeout_s``: the link is "down" when no HEARTBEAT of the target came for this long.
    ``cancel`` (anything with ``is_set()``, e.g. the service's stop flag): once set, a command or mission
    exchange waiting for the autopilot gives up within :data:`WAIT_SLICE_S` with LinkError, so a service
    told to stop is not held for seconds of retries by an autopilot that went quiet.
    """

    def __init__(self, url: str, *, target_system: int = 1, target_component: int = 0,
                 source_system: int = 245, source_component: int = mavlink2.MAV_COMP_ID_ONBOARD_COMPUTER,
                 signing_key: bytes | None = None, link_id: int = 0, link_timeout_s: float = 3.0,
                 heartbeat_hz: float = 1.0, cancel=None) -> None:
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
        self._fix_type: int | None = None
        self._att: tuple[float, float, float] | None = None
        self._boot_offset_s: float | None = None
        self._last_hb = -math.inf
        self.autopilot: int | None = None            # HEARTBEAT.autopilot of the target (MAV_AUTOPILOT_*)
        self._mission_q: queue.Queue = queue.Queue()
        self._ack_q: queue.Queue = queue.Queue()
        self._stop = threading.Event()
        self._cancel = cancel
        self._thread: threading.Thread | None = None
        self._tx_lock = threading.Lock()
        self.counters = {"received": 0, "ignored_source": 0, "bad": 0, "out_of_range": 0, "reconnects": 0,
                         "not_for_us": 0}
        self._transport = None
        self._reply_addr = (self.host, self.port) if self.kind == "udpout" else None
        # our own framing and signature checks, on every transport (see the module docstring)
        self._parser = MavlinkParser(datagram=self.kind in ("udpin", "udpout"), signing_key=signing_key)
        self._mav = mavlink2.MAVLink(_Sink(self), source_system, source_component)   # sending only
        if signing_key is not None:
            self._mav.signing.secret_key = signing_key
            self._mav.signing.link_id = link_id
            self._mav.signing.sign_outgoing = True
            self._mav.signing.timestamp = signing_timestamp()

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

    def __enter__(self) -> "AutopilotLink":
        return self.start()

    def __exit__(self, *exc) -> None:
        self.close()

    def _open(self) -> None:
        if self.kind in ("udpin", "udpout"):
            try:
                self._transport = _UdpTransport(self.kind, self.host, self.port)
            except OSError as exc:
                raise LinkError(self.url, str(exc)) from None
        else:
            self._transport = _StreamTransport(self.url, self.kind, self.host, self.port)

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

    @property
    def reply_addr(self):
        """Where UDP replies go: the udpout address, or (udpin) the address the target last spoke from."""
        return self._reply_addr

    @property
    def mission_convention(self) -> str | None:
        """ARDUPILOT (home at seq 0) or STANDARD (PX4 and the MAVLink spec); None before a HEARTBEAT."""
        if self.autopilot is None:
            return None
        return ARDUPILOT if self.autopilot == mavlink2.MAV_AUTOPILOT_ARDUPILOTMEGA else STANDARD

    # --- I/O loop ----------------------------------------------------------------------------------
    def send(self, msg) -> None:
        with self._tx_lock:
            if self.signing_key is not None:   # a signing timestamp follows the clock, not only the count
                self._mav.signing.timestamp = max(self._mav.signing.timestamp, signing_timestamp())
            self._mav.send(msg)

    def _heartbeat(self) -> None:
        self.send(mavlink2.MAVLink_heartbeat_message(
            mavlink2.MAV_TYPE_ONBOARD_CONTROLLER, mavlink2.MAV_AUTOPILOT_INVALID, 0, 0, mavlink2.MAV_STATE_ACTIVE, 3))

    def _run(self) -> None:
        next_hb = 0.0
        while not self._stop.is_set():
            now = time.monotonic()
            if now >= next_hb:
                self._heartbeat()
                next_hb = now + self.heartbeat_period_s
            got = self._transport.recv()
            if isinstance(self._transport, _StreamTransport):
                self.counters["reconnects"] = self._transport.reconnects
            if got is not None:
                self.ingest(*got)

    def ingest(self, data: bytes, addr=None) -> list:
        """Parse what arrived (one UDP datagram from ``addr``, or the next chunk of a TCP/serial stream)
        and apply it; returns the messages from the target that were used. The I/O thread calls this;
        tests may feed it directly. On ``udpin`` the reply address becomes ``addr`` only when the
        datagram held a valid (and, with signing, validly signed) packet of the target."""
        used = [m for m in self._parser.parse(data) if self._handle(m)]
        self.counters["bad"] = self._parser.bad
        if used and addr is not None and self.kind == "udpin":
            self._reply_addr = addr
        return used

    def _from_target(self, m) -> bool:
        if m.get_srcSystem() != self.target_system:
            return False
        return self.target_component == 0 or m.get_srcComponent() == self.target_component

    def _for_us(self, m) -> bool:
        return getattr(m, "target_system", 0) in (0, self.source_system) and \
            getattr(m, "target_component", 0) in (0, self.source_component)

    def _handle(self, m) -> bool:
        if not self._from_target(m):
            self.counters["ignored_source"] += 1
            return False
        self.counters["received"] += 1
        t = m.get_type()
        if t == "HEARTBEAT":
            self._last_hb = time.monotonic()
            if m.autopilot != mavlink2.MAV_AUTOPILOT_INVALID:   # not a GCS or companion of that system
                self.autopilot = m.autopilot
        elif t == "SYSTEM_TIME":
            if m.time_unix_usec > 1_000_000_000 * 1_000_000:  # a real clock (after 2001)
                self._boot_offset_s = m.time_unix_usec * 1e-6 - m.time_boot_ms * 1e-3
        elif t == "GPS_RAW_INT":
            self._on_gps(m)
        elif t == "ATTITUDE":
            vals = (math.degrees(m.roll), math.degrees(m.pitch), math.degrees(m.yaw))
            if all(math.isfinite(v) and abs(v) <= 360.0 for v in vals):
                self._att = vals
            else:
                self.counters["out_of_range"] += 1
        elif t == "GLOBAL_POSITION_INT":
            self._on_position(m)
        elif t.startswith("MISSION_") or t == "COMMAND_ACK":
            if not self._for_us(m):
                self.counters["not_for_us"] += 1
            elif t == "COMMAND_ACK":
                self._ack_q.put(m)
            else:
                self._mission_q.put(m)
        return True

    def _on_gps(self, m) -> None:
        """GPS_RAW_INT: fix type and horizontal accuracy, as the receiver reports them (the service
        decides what is usable, see VehicleState.usable_fix). h_acc (mm) is a MAVLink 2 extension,
        0 when not sent; the fix type is 0-8 (GPS_FIX_TYPE)."""
        h = getattr(m, "h_acc", 0)
        self._h_acc = h / 1000.0 if h else None
        self._fix_type = m.fix_type if 0 <= m.fix_type <= 8 else None
        with self._lock:  # autopilots send it before or after the position: apply it either way
            if self._state is not None:
                self._state = replace(self._state, h_acc_m=self._h_acc, fix_type=self._fix_type)

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
        att = self._att or (None, None, None)
        st = VehicleState(stamp, src, lat, lon, alt_amsl, alt_rel, heading, ve, vn, self._h_acc,
                          roll_deg=att[0], pitch_deg=att[1], yaw_deg=att[2], fix_type=self._fix_type)
        with self._lock:
            self._state = st

    # --- commands ----------------------------------------------------------------------------------
    def command_long(self, command: int, *params: float, timeout_s: float = 0.5, retries: int = 3) -> int:
        """Send COMMAND_LONG (up to 7 params, the rest 0) and return the MAV_RESULT of its COMMAND_ACK;
        a lost command is sent again with ``confirmation`` counting up. LinkError when no ACK comes."""
        if len(params) > 7:
            raise ValueError(f"params: COMMAND_LONG has 7 params, got {len(params)}")
        p = [float(v) for v in params] + [0.0] * (7 - len(params))
        tc = max(self.target_component, 1)
        self._drain(self._ack_q)
        for confirmation in range(retries + 1):
            self.send(mavlink2.MAVLink_command_long_message(self.target_system, tc, command, confirmation % 256, *p))
            deadline = time.monotonic() + timeout_s
            while (ack := self._get(self._ack_q, deadline)) is not None:
                if ack.command == command and ack.result != mavlink2.MAV_RESULT_IN_PROGRESS:
                    return ack.result
        raise LinkError(self.url, f"no COMMAND_ACK for command {command}")

    # --- mission protocol ----------------------------------------------------------------------------
    @staticmethod
    def _drain(q: queue.Queue) -> None:
        while True:
            try:
                q.get_nowait()
            except queue.Empty:
                return

    def _check_cancelled(self) -> None:
        if self._stop.is_set() or (self._cancel is not None and self._cancel.is_set()):
            raise LinkError(self.url, "stopped while waiting for the autopilot")

    def _get(self, q: queue.Queue, deadline: float):
        """The next message of ``q`` before ``deadline`` (monotonic), else None; LinkError once cancelled."""
        while True:
            self._check_cancelled()
            left = deadline - time.monotonic()
            if left <= 0:
                return None
            try:
                return q.get(timeout=min(left, WAIT_SLICE_S))
            except queue.Empty:
                continue

    def _await(self, types: tuple[str, ...], timeout_s: float, seq: int | None = None):
        deadline = time.monotonic() + timeout_s
        while True:
            m = self._get(self._mission_q, deadline)
            if m is None:
                return None
            if m.get_type() in types and (seq is None or getattr(m, "seq", seq) == seq):
                if getattr(m, "mission_type", 0) not in (0, None):
                    continue
                return m

    def _convention(self, wait_s: float) -> str:
        deadline = time.monotonic() + wait_s
        while self.mission_convention is None and time.monotonic() < deadline:
            self._check_cancelled()
            time.sleep(0.02)
        conv = self.mission_convention
        if conv is None:
            raise LinkError(self.url, "no HEARTBEAT from the autopilot yet: cannot tell its mission convention")
        return conv

    def _home_placeholder(self) -> MissionItem:
        """Item 0 for ArduPilot, which keeps HOME there and ignores what is uploaded to it."""
        st = self.state()
        lat, lon, alt = (st.lat_deg, st.lon_deg, st.alt_amsl_m) if st is not None else (0.0, 0.0, 0.0)
        return MissionItem(mavlink2.MAV_CMD_NAV_WAYPOINT, lat, lon, alt, frame=mavlink2.MAV_FRAME_GLOBAL)

    def wire_items(self, items: list[MissionItem], convention: str) -> list[MissionItem]:
        """The items as they go on the wire for an autopilot of this convention (see module docstring)."""
        if convention == ARDUPILOT:
            return [self._home_placeholder()] + [replace(it, current=0) for it in items]
        return [replace(it, current=int(k == 0)) for k, it in enumerate(items)]

    def download_mission(self, *, timeout_s: float = 0.5, retries: int = 5) -> list[MissionItem]:
        """The vehicle's mission items (plain mission type; ArduPilot's HOME at seq 0 left out), each with
        the ``current`` flag the vehicle reported; LinkError when it cannot."""
        convention = self._convention(timeout_s * retries)
        ts, tc = self.target_system, max(self.target_component, 1)
        self._drain(self._mission_q)
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
        return items[1:] if convention == ARDUPILOT else items

    def upload_mission(self, items: list[MissionItem], *, timeout_s: float = 0.5, retries: int = 5) -> None:
        """Replace the vehicle's mission; LinkError unless the vehicle ACKs it as accepted.

        The autopilot's convention is applied here (see :meth:`wire_items`): ArduPilot gets a HOME
        placeholder at seq 0 and ``current`` 0 everywhere (it ignores the flag on upload); PX4 and any
        standard autopilot get the first item marked ``current``, where the mission starts."""
        wire = self.wire_items(items, self._convention(timeout_s * retries))
        ts, tc = self.target_system, max(self.target_component, 1)
        self._drain(self._mission_q)
        count = mavlink2.MAVLink_mission_count_message(ts, tc, len(wire), mavlink2.MAV_MISSION_TYPE_MISSION)
        self.send(count)
        sent_any = False
        misses = 0
        while True:
            m = self._await(("MISSION_REQUEST_INT", "MISSION_REQUEST", "MISSION_ACK"), timeout_s)
            if m is None:
                misses += 1
                if misses > retries:
                    raise LinkError(self.url, "mission upload timed out")
                if not sent_any:  # the COUNT may have been lost
                    self.send(count)
                continue
            if m.get_type() == "MISSION_ACK":
                if m.type == mavlink2.MAV_MISSION_ACCEPTED:
                    return
                raise LinkError(self.url, f"mission rejected by the vehicle (MAV_MISSION_RESULT {m.type})")
            if not 0 <= m.seq < len(wire):
                raise LinkError(self.url, f"vehicle asked for item {m.seq} of {len(wire)}")
            self.send(wire[m.seq].to_msg(m.seq, ts, tc))
            sent_any = True
            misses = 0
