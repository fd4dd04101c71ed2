"""`uvteam bridge`: the team's crowds and vehicles in the formats operators' tools read, live.

    uvteam bridge --team demo --connect tcp/10.0.0.1:7447 \\
        --geojson /srv/www/crowds.geojson --geojson-stream - \\
        --kml crowds.kml --kmz crowds.kmz --csv crowds.csv \\
        --cot udp://239.2.3.1:6969 --mavlink udpout:127.0.0.1:14550

Outputs (any number, combined):
  --geojson FILE          RFC 7946 FeatureCollection, rewritten atomically (QGIS, geojson.io)
  --geojson-stream FILE   newline-delimited GeoJSON Features appended per update; "-" is stdout
  --kml FILE, --kmz FILE  KML 2.2 with gx:Track per crowd and vehicle (Google Earth), written every
                          --kml-period-s and at exit
  --csv FILE              one row per crowd per frame, with MGRS, appended (header when new)
  --cot URL               Cursor-on-Target events to ATAK/WinTAK: udp://GROUP:PORT (the TAK multicast
                          default udp://239.2.3.1:6969, or a unicast address) or tcp://HOST:PORT (a TAK
                          server's plain streaming input)
  --mavlink URL           ADSB_VEHICLE traffic + HEARTBEAT to QGroundControl / Mission Planner:
                          udpout:HOST:PORT (the GCS's UDP port, 14550 by default in both)

It listens to uvteam/<team>/*/crowds, */fix and */status. Stops on Ctrl-C or SIGTERM (files are written
once more). Every field and how to open each output in its tool: docs/formats.md.
"""

from __future__ import annotations

import argparse
import logging
import os
import queue
import socket
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Callable, TextIO
from urllib.parse import urlsplit

from uvteam import keys
from uvteam.bus import BusConfig
from uvteam.errors import ConfigError, LinkError
from uvteam.formats import Picture, adsb, cot, crowd_csv, geojson, kml
from uvteam.formats.picture import CrowdSeen, VehicleSeen
from uvteam.io.zenoh_bus import ZenohBus, add_bus_args, bus_config_from_args
from uvteam.messages import Crowds, Fix, Status
from uvteam.service import StopFlag, setup_logging

log = logging.getLogger("uvteam.bridge")

TAK_MULTICAST = "udp://239.2.3.1:6969"


def write_atomic(path: Path, data: bytes) -> None:
    """Replace ``path`` with ``data`` so a reader sees the old file or the new one, never half of one."""
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        # mkstemp makes 0600; keep an existing file's mode, else readable by all (a web server serves it)
        os.fchmod(fd, path.stat().st_mode & 0o777 if path.exists() else 0o644)
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        raise


class CotSender:
    """CoT events over UDP (one event per datagram; multicast or unicast) or TCP (a stream of events,
    reconnected in the background, events dropped while the server is away)."""

    def __init__(self, url: str, ttl: int = 1, iface: str | None = None) -> None:
        u = urlsplit(url)
        if u.scheme not in ("udp", "tcp") or not u.hostname or not u.port:
            raise ConfigError("--cot", "url", f"expected udp://HOST:PORT or tcp://HOST:PORT, got {url!r}")
        self.url, self.kind, self.addr = url, u.scheme, (u.hostname, u.port)
        self.sent = self.dropped = 0
        self._sock: socket.socket | None = None
        if self.kind == "udp":
            self._sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
            if _is_multicast(u.hostname):
                self._sock.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_TTL, ttl)
                if iface:
                    self._sock.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_IF, socket.inet_aton(iface))
        else:
            self._queue: queue.Queue[bytes | None] = queue.Queue(maxsize=1000)
            self._thread = threading.Thread(target=self._tcp_loop, name="cot-tcp", daemon=True)
            self._thread.start()

    def send(self, event: str) -> None:
        data = event.encode("utf-8")
        if self.kind == "udp":
            try:
                self._sock.sendto(data, self.addr)
                self.sent += 1
            except OSError as exc:
                self.dropped += 1
                log.warning("CoT to %s: %s", self.url, exc)
            return
        try:
            self._queue.put_nowait(data)
        except queue.Full:
            self.dropped += 1

    def _tcp_loop(self) -> None:
        backoff_s = 0.5
        sock = None
        while True:
            data = self._queue.get()
            if data is None:
                break
            while sock is None:
                try:
                    sock = socket.create_connection(self.addr, timeout=3.0)
                    log.info("CoT: connected to %s", self.url)
                    backoff_s = 0.5
                except OSError as exc:
                    log.warning("CoT: cannot connect to %s (%s); retrying in %.1f s", self.url, exc, backoff_s)
                    time.sleep(backoff_s)
                    backoff_s = min(backoff_s * 2.0, 10.0)
                    if self._queue.qsize() > 100:        # the server is away: keep the newest, count the rest
                        self.dropped += 1
                        data = self._queue.get()
                        if data is None:
                            return
            try:
                sock.sendall(data)
                self.sent += 1
            except OSError as exc:
                log.warning("CoT: %s lost (%s)", self.url, exc)
                self.dropped += 1
                sock.close()
                sock = None
        if sock is not None:
            sock.close()

    def close(self) -> None:
        if self.kind == "udp":
            self._sock.close()
        else:
            try:
                self._queue.put(None, timeout=1.0)
            except queue.Full:
                pass
            self._thread.join(timeout=2.0)


def _is_multicast(host: str) -> bool:
    try:
        return 224 <= int(socket.inet_aton(host)[0]) <= 239
    except OSError:
        return False


class MavlinkSender:
    """MAVLink datagrams to a ground station: udpout:HOST:PORT (the GCS listens, we send first)."""

    def __init__(self, url: str) -> None:
        kind, _, rest = url.partition(":")
        host, _, port = rest.rpartition(":")
        if kind != "udpout" or not host or not port.isdigit() or not 0 < int(port) < 65536:
            raise ConfigError("--mavlink", "url", f"expected udpout:HOST:PORT, got {url!r}")
        self.url, self.addr = url, (host, int(port))
        self._sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sent = 0

    def send(self, frames: list[bytes]) -> None:
        for f in frames:
            try:
                self._sock.sendto(f, self.addr)
                self.sent += 1
            except OSError as exc:       # e.g. ECONNREFUSED from an earlier datagram: the GCS is not up yet
                log.debug("MAVLink to %s: %s", self.url, exc)

    def close(self) -> None:
        self._sock.close()


class Bridge:
    """The bridge's loop body: messages in (on the loop's thread), outputs out. Owns every sink."""

    def __init__(self, args: argparse.Namespace, team: str) -> None:
        self.args, self.team = args, team
        interval_s = args.tracking_interval_s
        self.stale_s = args.cot_stale_intervals * interval_s
        self.picture = Picture(team, max_age_s=args.max_age_s or self.stale_s, max_track_points=args.track_points,
                               track_period_s=args.track_period_s)
        self.geojson_path = Path(args.geojson) if args.geojson else None
        self.kml_path = Path(args.kml) if args.kml else None
        self.kmz_path = Path(args.kmz) if args.kmz else None
        self.csv_path = Path(args.csv) if args.csv else None
        for p in (self.geojson_path, self.kml_path, self.kmz_path, self.csv_path):
            if p is not None and not p.parent.is_dir():
                raise ConfigError(str(p), "output", "its directory does not exist")
        self.stream: TextIO | None = None
        if args.geojson_stream == "-":
            self.stream = sys.stdout
        elif args.geojson_stream:
            self.stream = open(args.geojson_stream, "a", encoding="utf-8")
        self.csv: TextIO | None = None
        if self.csv_path is not None:
            new = not self.csv_path.exists() or self.csv_path.stat().st_size == 0
            if not new:
                with open(self.csv_path, encoding="utf-8", newline="") as f:
                    head = f.readline()
                if head != crowd_csv.HEADER:     # another version's columns: rows would not line up
                    raise ConfigError(str(self.csv_path), "csv", f"its header is not {crowd_csv.HEADER.strip()}; "
                                      "give a new file")
            self.csv = open(self.csv_path, "a", encoding="utf-8", newline="")
            if new:
                self.csv.write(crowd_csv.HEADER)
                self.csv.flush()
        self.cot = CotSender(args.cot, args.cot_ttl, args.cot_iface) if args.cot else None
        self.mavlink = MavlinkSender(args.mavlink) if args.mavlink else None
        self.encoder = adsb.AdsbEncoder(args.mavlink_sysid, args.mavlink_compid, args.mavlink_icao_base) \
            if args.mavlink else None
        self._geojson_dirty = False
        self._geojson_uids: set[str] | None = None      # the crowds in the file last written
        self._last_geojson = self._last_kml = self._last_mavlink = self._last_heartbeat = -1e18
        self._last_cot: dict[str, float] = {}
        self.counts = {"crowds": 0, "fix": 0, "status": 0}

    # ---- messages in
    def on_crowds(self, msg: Crowds) -> None:
        self.counts["crowds"] += 1
        seen = self.picture.add_crowds(msg)
        self._geojson_dirty = True
        if self.csv is not None and seen:
            self.csv.write(crowd_csv.rows(seen))
            self.csv.flush()
        if self.stream is not None and seen:
            self.stream.write(geojson.feature_lines(f for c in seen for f in geojson.crowd_features(c)))
            self.stream.flush()
        if self.cot is not None:
            for c in seen:
                self._send_cot(c, now_s=time.monotonic())

    def on_fix(self, msg: Fix) -> None:
        self.counts["fix"] += 1
        v = self.picture.add_fix(msg)
        if v is None:
            return
        self._geojson_dirty = True
        if self.stream is not None:
            self.stream.write(geojson.feature_lines([geojson.vehicle_feature(v)]))
            self.stream.flush()
        if self.cot is not None and not self.args.cot_no_vehicles:
            self._send_cot(v, now_s=time.monotonic())

    def on_status(self, msg: Status) -> None:
        self.counts["status"] += 1
        self.picture.add_status(msg)

    def _send_cot(self, item: CrowdSeen | VehicleSeen, now_s: float) -> None:
        """At most one event per uid per --cot-period-s (a localizer reports crowds at the camera's rate)."""
        if now_s - self._last_cot.get(item.uid, -1e18) < self.args.cot_period_s:
            return
        self._last_cot[item.uid] = now_s
        if isinstance(item, CrowdSeen):
            self.cot.send(cot.crowd_event(item, self.stale_s, cot_type=self.args.cot_type))
        else:
            self.cot.send(cot.vehicle_event(item, self.stale_s))

    # ---- timers
    def tick(self, mono_s: float, now_s: float) -> None:
        if self.geojson_path and not self._geojson_dirty and self._geojson_uids is not None:
            # a quiet team: crowds age out of the picture with no message to say so
            self._geojson_dirty = {c.uid for c in self.picture.snapshot(now_s).crowds} != self._geojson_uids
        if self.geojson_path and self._geojson_dirty and mono_s - self._last_geojson >= self.args.geojson_period_s:
            self.write_geojson(now_s)
            self._last_geojson = mono_s
        if (self.kml_path or self.kmz_path) and mono_s - self._last_kml >= self.args.kml_period_s:
            self.write_kml(now_s)
            self._last_kml = mono_s
        if self.mavlink is not None:
            if mono_s - self._last_heartbeat >= 1.0:
                self.mavlink.send([self.encoder.heartbeat()])
                self._last_heartbeat = mono_s
            if mono_s - self._last_mavlink >= 1.0 / self.args.mavlink_rate_hz:
                self.mavlink.send(self.encoder.crowds(self.picture.snapshot(now_s), now_s))
                self._last_mavlink = mono_s

    # ---- files
    def write_geojson(self, now_s: float) -> None:
        snap = self.picture.snapshot(now_s)
        write_atomic(self.geojson_path, geojson.dumps(geojson.feature_collection(snap)).encode("utf-8"))
        self._geojson_dirty = False
        self._geojson_uids = {c.uid for c in snap.crowds}

    def write_kml(self, now_s: float) -> None:
        text = kml.document(self.picture.snapshot(now_s), self.picture.crowd_tracks(), self.picture.vehicle_tracks())
        if self.kml_path:
            write_atomic(self.kml_path, text.encode("utf-8"))
        if self.kmz_path:
            write_atomic(self.kmz_path, kml.kmz(text))

    def close(self, now_s: float) -> None:
        """Write the files once more, then close every sink."""
        try:
            if self.geojson_path:
                self.write_geojson(now_s)
            if self.kml_path or self.kmz_path:
                self.write_kml(now_s)
        finally:
            if self.stream is not None and self.stream is not sys.stdout:
                self.stream.close()
            if self.csv is not None:
                self.csv.close()
            if self.cot is not None:
                self.cot.close()
            if self.mavlink is not None:
                self.mavlink.close()


def _positive(kind: type, name: str) -> Callable[[str], float]:
    def parse(text: str):
        v = kind(text)
        if not v > 0:
            raise argparse.ArgumentTypeError(f"{name} must be > 0, got {text}")
        return v
    return parse


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(prog="uvteam bridge", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--team", required=True, help="the team id (the <team> in uvteam/<team>/...)")
    out = ap.add_argument_group("outputs")
    out.add_argument("--geojson", metavar="FILE", help="FeatureCollection file, rewritten atomically on updates")
    out.add_argument("--geojson-period-s", type=_positive(float, "--geojson-period-s"), default=0.5,
                     help="rewrite the GeoJSON file at most this often (default 0.5)")
    out.add_argument("--geojson-stream", metavar="FILE|-", help="newline-delimited GeoJSON, appended; - = stdout")
    out.add_argument("--kml", metavar="FILE", help="KML 2.2 file with tracks, written every --kml-period-s and at exit")
    out.add_argument("--kmz", metavar="FILE", help="the same as KMZ (zipped doc.kml)")
    out.add_argument("--kml-period-s", type=_positive(float, "--kml-period-s"), default=10.0,
                     help="rewrite KML/KMZ this often (default 10)")
    out.add_argument("--csv", metavar="FILE", help="CSV with MGRS, one row per crowd per frame, appended")
    out.add_argument("--cot", metavar="URL", nargs="?", const=TAK_MULTICAST,
                     help=f"Cursor-on-Target: udp://HOST:PORT or tcp://HOST:PORT (bare --cot: {TAK_MULTICAST})")
    out.add_argument("--cot-type", default=cot.CROWD_TYPE, help="CoT type of a crowd (default a-u-G: unknown ground)")
    out.add_argument("--cot-stale-intervals", type=_positive(float, "--cot-stale-intervals"), default=5.0,
                     help="stale = time + this many tracking intervals (default 5)")
    out.add_argument("--cot-period-s", type=float, default=1.0,
                     help="send each crowd's / vehicle's event at most this often (default 1; 0 = every update)")
    out.add_argument("--cot-no-vehicles", action="store_true", help="send crowds only, not the team's vehicles")
    out.add_argument("--cot-ttl", type=int, default=1, help="multicast TTL (default 1: this network only)")
    out.add_argument("--cot-iface", metavar="ADDR", help="send multicast from the interface with this IPv4 address")
    out.add_argument("--mavlink", metavar="URL", help="ADSB_VEHICLE to a ground station: udpout:HOST:PORT")
    out.add_argument("--mavlink-sysid", type=int, default=1,
                     help="MAVLink system id to send as (default 1: QGC draws traffic only from a system it "
                          "knows, usually the autopilot's)")
    out.add_argument("--mavlink-compid", type=int, default=adsb.DEFAULT_COMPID,
                     help="component id (default 191, onboard computer; 1 makes QGC create a vehicle for it)")
    out.add_argument("--mavlink-rate-hz", type=_positive(float, "--mavlink-rate-hz"), default=1.0,
                     help="ADSB_VEHICLE updates per second (default 1)")
    out.add_argument("--mavlink-icao-base", type=lambda s: int(s, 0), default=adsb.DEFAULT_ICAO_BASE,
                     help="first 24-bit ICAO address for crowds (default 0xF00000)")
    ap.add_argument("--tracking-interval-s", type=_positive(float, "--tracking-interval-s"), default=1.0,
                    help="the team's tracking interval (default 1.0, as in deploy/vehicles)")
    ap.add_argument("--max-age-s", type=float, default=0.0,
                    help="drop a localizer's crowds after this long without news (default: the CoT stale time)")
    ap.add_argument("--track-period-s", type=float, default=1.0,
                    help="keep one track point per crowd / vehicle per this many seconds (default 1)")
    ap.add_argument("--track-points", type=_positive(int, "--track-points"), default=3600,
                    help="keep this many points per track (default 3600: an hour at 1 s)")
    ap.add_argument("--duration", type=float, default=0.0, help="exit after this many seconds (0 = until stopped)")
    ap.add_argument("--log-level", default="INFO", choices=["DEBUG", "INFO", "WARNING", "ERROR"])
    add_bus_args(ap)
    args = ap.parse_args(argv)
    if not any((args.geojson, args.geojson_stream, args.kml, args.kmz, args.csv, args.cot, args.mavlink)):
        ap.error("choose at least one output (--geojson, --geojson-stream, --kml, --kmz, --csv, --cot, --mavlink)")
    return args


def _guarded(fn, *args) -> None:
    """One output failing (a full disk, a file someone removed) must not stop the others: logged, at most
    once per 10 s per kind of failure."""
    try:
        fn(*args)
    except OSError as exc:
        key = (getattr(fn, "__name__", "?"), type(exc).__name__)
        now = time.monotonic()
        if now - _last_io_error.get(key, -1e18) >= 10.0:
            _last_io_error[key] = now
            log.error("output failed in %s: %s", key[0], exc)


_last_io_error: dict[tuple[str, str], float] = {}


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    try:
        team = keys.check_id("team", args.team)
        bridge = Bridge(args, team)
    except (ConfigError, ValueError, OSError) as exc:
        print(f"uvteam bridge: configuration error: {exc}", file=sys.stderr)
        return 2
    setup_logging(f"{team}/bridge", args.log_level)
    stop = StopFlag()
    inbox: queue.Queue = queue.Queue(maxsize=10000)

    def enqueue(handler):
        def put(_key, msg) -> None:                  # on zenoh's thread: hand over, never block it long
            try:
                inbox.put(((handler, msg)), timeout=0.5)
            except queue.Full:
                log.warning("inbox full: dropped a message")
        return put

    try:
        bus = ZenohBus.open(bus_config_from_args(args, BusConfig(mode="peer")))
    except (LinkError, ConfigError) as exc:
        log.error("cannot open the bus: %s", exc)
        bridge.close(time.time())
        return 3 if isinstance(exc, LinkError) else 2
    t_end = time.monotonic() + args.duration if args.duration > 0 else float("inf")
    try:
        with bus:
            bus.subscribe(keys.all_vehicles(team, "crowds"), Crowds, enqueue(bridge.on_crowds))
            bus.subscribe(keys.all_vehicles(team, "fix"), Fix, enqueue(bridge.on_fix))
            bus.subscribe(keys.all_vehicles(team, "status"), Status, enqueue(bridge.on_status))
            log.info("bridge for team %s up", team)
            while not stop.is_set() and time.monotonic() < t_end:
                try:
                    handler, msg = inbox.get(timeout=0.05)
                    while True:                      # drain what else has arrived before the timers
                        _guarded(handler, msg)
                        handler, msg = inbox.get_nowait()
                except queue.Empty:
                    pass
                _guarded(bridge.tick, time.monotonic(), time.time())
            log.info("bridge stopping: received %s, bad %d", bridge.counts, bus.rejected_total)
    finally:
        bridge.close(time.time())
    return 0
