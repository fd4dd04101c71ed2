"""`uvteam map`: the team on a live map in the browser, from zenoh, with no internet.

    uvteam map --team demo --connect tcp/127.0.0.1:7447             then open http://127.0.0.1:8770/
    uvteam map --team border1 --connect tcp/10.0.0.1:7447 --basemap maps/sasabe.mbtiles
    uvteam map --team border1 --mode peer --listen tcp/0.0.0.0:7448 --http 127.0.0.1:9000
    uvteam map --team demo -e tcp/127.0.0.1:7447 --video http://127.0.0.1:8771/stream.mjpg

Draws the UAV with its camera footprint, the UGVs with heading, trail, plan and alive/stale state,
and every crowd with its footprint, 95 % circle, velocity arrow, track and quality; a side list
gives each crowd's lat/lon and MGRS. Without a basemap the map is a metric grid (metres east/north
of the first fix, or --origin) with a scale bar and a north arrow. With --video, what the UAV sees
(its annotated camera, MJPEG from the UAV service's [uav].annotate_http) is shown beside the map.
The page is served from 127.0.0.1 unless --http says otherwise; it gets updates by server-sent
events at --rate-hz.
Camera frames are never subscribed to.
"""

from __future__ import annotations

import argparse
import json
import logging
import mimetypes
import re
import socket
import sys
import threading
import time
from http import HTTPStatus
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from urllib.parse import urlsplit

from uvteam import keys, messages
from uvteam.bus import BusConfig
from uvteam.errors import ConfigError, LinkError
from uvteam.io.zenoh_bus import ZenohBus, add_bus_args, bus_config_from_args
from uvteam.service import StopFlag, setup_logging

from .state import MapConfig, TeamView
from .tiles import CONTENT_TYPES, TileSource, open_basemap

__all__ = ["main", "MapServer", "subscriptions", "STATIC_DIR"]

log = logging.getLogger("uvteam.map")
STATIC_DIR = Path(__file__).resolve().parent / "static"
TOPICS = ("fix", "crowds", "status", "plan", "detections")     # never "frame": pixels stay on the vehicles
DEFAULT_HTTP = "127.0.0.1:8770"
_TILE = re.compile(r"^/tiles/(\d{1,2})/(\d{1,2})/(\d{1,8})/(\d{1,8})\.(png|jpg|webp)$")
_LOOPBACK_HOSTS = {"127.0.0.1", "localhost", "::1"}


def subscriptions(team: str) -> list[tuple[str, type]]:
    """The key expressions the map subscribes to, one per topic (so frames are never routed here)."""
    return [(keys.all_vehicles(team, t), messages.BY_TOPIC[t]) for t in TOPICS]


def parse_hostport(text: str) -> tuple[str, int]:
    m = re.fullmatch(r"\[?([^\[\]]*?)\]?:(\d{1,5})", text.strip())
    if not m or not m.group(1) or int(m.group(2)) > 65535:
        raise ConfigError("--http", "HOST:PORT", f"expected e.g. 127.0.0.1:8770, got {text!r}")
    return m.group(1), int(m.group(2))


def _pair(flag: str, text: str, lo=(-90.0, -180.0), hi=(90.0, 180.0)) -> tuple[float, float]:
    try:
        a, b = (float(v) for v in text.split(","))
    except ValueError:
        raise ConfigError(flag, "LAT,LON", f"expected two numbers separated by a comma, got {text!r}") from None
    if not (lo[0] <= a <= hi[0] and lo[1] <= b <= hi[1]):
        raise ConfigError(flag, "LAT,LON", f"latitude in [-90, 90] and longitude in [-180, 180], got {text!r}")
    return a, b


def _size(text: str) -> tuple[int, int]:
    m = re.fullmatch(r"(\d+)x(\d+)", text.strip())
    if not m or int(m.group(1)) == 0 or int(m.group(2)) == 0:
        raise ConfigError("--image-size", "WxH", f"expected e.g. 1280x720, got {text!r}")
    return int(m.group(1)), int(m.group(2))


class MapServer(ThreadingHTTPServer):
    """The page, its static files, /state.json, /events (server-sent events) and /tiles/."""

    daemon_threads = True
    allow_reuse_address = True

    def __init__(self, addr: tuple[str, int], view: TeamView, *, basemaps: list[TileSource] = (),
                 rate_hz: float = 5.0, center: tuple[float, float] | None = None, zoom: int | None = None,
                 bus_counts=None, video: str | None = None) -> None:
        self.view, self.basemaps, self.rate_hz, self.video = view, list(basemaps), rate_hz, video
        self.center, self.zoom = center, zoom
        self.bus_counts = bus_counts or (lambda: {})
        self.stopping = threading.Event()
        self.address_family = socket.AF_INET6 if ":" in addr[0] else socket.AF_INET
        super().__init__(addr, _Handler)
        self.loopback_only = addr[0] in _LOOPBACK_HOSTS or addr[0].startswith("127.")

    @property
    def url(self) -> str:
        host, port = self.server_address[:2]
        host = f"[{host}]" if ":" in host else host
        return f"http://{host}:{port}/"

    def client_config(self) -> dict:
        return {
            "team": self.view.cfg.team, "video": self.video,
            "rate_hz": self.rate_hz, "arrow_s": self.view.cfg.arrow_s, "center": self.center, "zoom": self.zoom,
            "origin": list(self.view.cfg.origin) if self.view.cfg.origin else None,
            "basemaps": [{"name": b.info.name, "url": f"tiles/{i}/{{z}}/{{x}}/{{y}}.{b.info.fmt}",
                          "min_zoom": b.info.min_zoom, "max_zoom": b.info.max_zoom, "bounds": b.info.bounds,
                          "attribution": b.info.attribution} for i, b in enumerate(self.basemaps)],
        }

    def snapshot(self) -> dict:
        snap = self.view.snapshot(time.time())
        snap["bus"] = self.bus_counts()
        return snap

    def shutdown(self) -> None:
        self.stopping.set()
        with self.view.changed:
            self.view.changed.notify_all()
        super().shutdown()


class _Handler(BaseHTTPRequestHandler):
    server: MapServer
    protocol_version = "HTTP/1.1"

    def log_message(self, fmt: str, *args) -> None:
        log.debug("%s " + fmt, self.address_string(), *args)

    def _send(self, status: int, body: bytes, ctype: str, cache: str = "no-cache") -> None:
        self.send_response(status)
        self.send_header("Content-Type", ctype)
        self.send_header("Content-Length", str(len(body)))
        self.send_header("Cache-Control", cache)
        self.send_header("X-Content-Type-Options", "nosniff")
        self.end_headers()
        if self.command != "HEAD":
            self.wfile.write(body)

    def _json(self, obj) -> None:
        self._send(200, json.dumps(obj, separators=(",", ":")).encode(), "application/json", "no-store")

    def _not_found(self) -> None:
        self._send(404, b"not found\n", "text/plain; charset=utf-8")

    def do_HEAD(self) -> None:
        self.do_GET()

    def do_GET(self) -> None:
        # a page bound to loopback answers loopback names only (no DNS rebinding from a web page)
        host = self.headers.get("Host") or ""
        name = host[1:].split("]")[0] if host.startswith("[") else host.split(":")[0]
        if self.server.loopback_only and name not in _LOOPBACK_HOSTS and not name.startswith("127."):
            self._send(403, b"this map answers on loopback names only\n", "text/plain; charset=utf-8")
            return
        path = urlsplit(self.path).path
        if path in ("/", "/index.html"):
            return self._static("index.html")
        if path.startswith("/static/"):
            return self._static(path[len("/static/"):])
        if path == "/config.json":
            return self._json(self.server.client_config())
        if path == "/state.json":
            return self._json(self.server.snapshot())
        if path == "/events":
            return self._events()
        if path == "/favicon.ico":
            return self._send(204, b"", "image/x-icon")
        m = _TILE.match(path)
        if m:
            return self._tile(*(int(g) for g in m.groups()[:4]))
        self._not_found()

    def _static(self, rel: str) -> None:
        root = STATIC_DIR
        f = (root / rel).resolve()
        if root not in f.parents or not f.is_file():
            return self._not_found()
        ctype = mimetypes.guess_type(f.name)[0] or "application/octet-stream"
        if ctype.startswith("text/") or ctype in ("application/javascript", "text/javascript"):
            ctype += "; charset=utf-8"
        self._send(200, f.read_bytes(), ctype)

    def _tile(self, i: int, z: int, x: int, y: int) -> None:
        if i >= len(self.server.basemaps) or x >= (1 << z) or y >= (1 << z):
            return self._not_found()
        src = self.server.basemaps[i]
        data = src.tile(z, x, y)
        if data is None:
            return self._not_found()
        self._send(200, data, CONTENT_TYPES[src.info.fmt], "max-age=3600")

    def _events(self) -> None:
        """Server-sent events: the whole snapshot when it changed, at most rate_hz, and at least once
        a second (ages and staleness move on without messages)."""
        srv, view = self.server, self.server.view
        self.send_response(200)
        self.send_header("Content-Type", "text/event-stream")
        self.send_header("Cache-Control", "no-store")
        self.send_header("Connection", "keep-alive")
        self.end_headers()
        self.close_connection = True
        period = 1.0 / srv.rate_hz
        sent_version = -1
        try:
            self.wfile.write(b"retry: 1000\n\n")
            while not srv.stopping.is_set():
                t0 = time.monotonic()
                data = json.dumps(srv.snapshot(), separators=(",", ":"))
                sent_version = srv.view.version
                self.wfile.write(f"event: state\ndata: {data}\n\n".encode())
                self.wfile.flush()
                with view.changed:
                    view.changed.wait_for(lambda: view.version != sent_version or srv.stopping.is_set(),
                                          timeout=1.0)
                rest = period - (time.monotonic() - t0)
                if rest > 0 and srv.stopping.wait(rest):
                    break
        except (BrokenPipeError, ConnectionResetError, TimeoutError):
            pass                                # the browser went away


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="uvteam map", description=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--team", required=True, help="the team id (uvteam/<team>/...)")
    ap.add_argument("--http", default=DEFAULT_HTTP, metavar="HOST:PORT",
                    help=f"where the page is served (default {DEFAULT_HTTP}; port 0 = any free port)")
    ap.add_argument("--basemap", action="append", default=[], metavar="DIR|FILE.mbtiles",
                    help="offline tiles: an XYZ folder {z}/{x}/{y}.png or an MBTiles file (repeatable)")
    ap.add_argument("--uav", default=None, metavar="ID", help="the UAV's id (default: who publishes detections)")
    ap.add_argument("--hfov-deg", type=float, default=78.0, help="UAV camera horizontal field of view (default 78)")
    ap.add_argument("--image-size", default="1280x720", metavar="WxH",
                    help="UAV image size, for the footprint when no detections arrive (default 1280x720)")
    ap.add_argument("--ground-amsl-m", type=float, default=None, metavar="M",
                    help="ground height AMSL: lets the footprint follow the UAV's fix altitude when no "
                         "detections (which carry the height above ground) arrive")
    ap.add_argument("--footprint-yaw", choices=["heading", "north"], default="heading",
                    help="camera fixed to the UAV body (heading, default) or on a north-up gimbal (north)")
    ap.add_argument("--stale-s", type=float, default=3.0, help="a fix older than this is drawn stale (default 3)")
    ap.add_argument("--origin", default=None, metavar="LAT,LON", help="grid origin (default: the first fix)")
    ap.add_argument("--center", default=None, metavar="LAT,LON", help="initial map centre (default: fit the team)")
    ap.add_argument("--zoom", type=int, default=None, help="initial zoom with --center (default 18)")
    ap.add_argument("--rate-hz", type=float, default=5.0, help="most updates a second sent to a browser (default 5)")
    ap.add_argument("--video", default=None, metavar="URL",
                    help="an MJPEG stream to show beside the map: what the UAV sees, from the UAV service's "
                         "[uav].annotate_http, e.g. http://127.0.0.1:8771/stream.mjpg")
    ap.add_argument("--duration", type=float, default=0.0, help="exit after this many seconds (0 = until Ctrl-C)")
    ap.add_argument("--log-level", default="INFO", choices=["DEBUG", "INFO", "WARNING", "ERROR"])
    add_bus_args(ap)
    args = ap.parse_args(argv)
    setup_logging("map", args.log_level)
    if args.video is not None and not re.fullmatch(r"https?://\S+", args.video):
        print(f"uvteam map: --video must be an http:// or https:// URL, got {args.video!r}", file=sys.stderr)
        return 2
    basemaps: list[TileSource] = []
    try:
        host, port = parse_hostport(args.http)
        w, h = _size(args.image_size)
        cfg = MapConfig(team=args.team, uav=args.uav, hfov_deg=args.hfov_deg, image_width_px=w, image_height_px=h,
                        ground_amsl_m=args.ground_amsl_m, footprint_yaw=args.footprint_yaw, stale_s=args.stale_s,
                        origin=_pair("--origin", args.origin) if args.origin else None)
        center = _pair("--center", args.center) if args.center else None
        if not 0 < args.rate_hz <= 50:
            raise ConfigError("--rate-hz", "rate", f"must be in (0, 50], got {args.rate_hz}")
        basemaps = [open_basemap(p) for p in args.basemap]
    except ConfigError as exc:
        print(f"uvteam map: {exc}", file=sys.stderr)
        return 2
    view = TeamView(cfg)
    try:
        bus = ZenohBus.open(bus_config_from_args(args, BusConfig(mode="client") if args.connect else None))
    except (LinkError, ConfigError) as exc:
        print(f"uvteam map: {exc}", file=sys.stderr)
        return 2 if isinstance(exc, ConfigError) else 3
    stop = StopFlag()
    try:
        with bus:
            handlers = {"fix": view.on_fix, "crowds": view.on_crowds, "status": view.on_status, "plan": view.on_plan,
                        "detections": view.on_detections}
            for (expr, cls), topic in zip(subscriptions(cfg.team), TOPICS):
                bus.subscribe(expr, cls, lambda k, m, h=handlers[topic]: h(k, m, time.time()))
            bus.watch_alive(keys.alive_all(cfg.team), lambda k, up: view.on_alive(k, up, time.time()))
            try:
                srv = MapServer((host, port), view, basemaps=basemaps, rate_hz=args.rate_hz, center=center,
                                zoom=args.zoom, bus_counts=lambda: {"received": bus.received,
                                                                    "rejected": bus.rejected_total},
                                video=args.video)
            except OSError as exc:
                print(f"uvteam map: cannot serve on {args.http}: {exc}", file=sys.stderr)
                return 3
            if not srv.loopback_only:
                log.warning("serving on %s: anyone who reaches this address sees the team", host)
            th = threading.Thread(target=srv.serve_forever, name="http", daemon=True)
            th.start()
            print(f"uvteam map: team {cfg.team} on {srv.url}", flush=True)
            t_end = time.monotonic() + args.duration if args.duration else float("inf")
            try:
                while not stop.wait(0.2) and time.monotonic() < t_end:
                    pass
            finally:
                srv.shutdown()
                srv.server_close()
                th.join(timeout=5)
    finally:
        for b in basemaps:
            b.close()
    return 0
