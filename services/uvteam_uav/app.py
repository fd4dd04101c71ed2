"""The UAV service shell: the MAVLink link, the camera and the zenoh bus around
:class:`uvteam.nodes.uav.UavNode`. Frames come from ``[uav].camera``: "zenoh" (the ``.../frame`` key,
which the simulator feeds; the node subscribes itself), or a device, file, RTSP URL or GStreamer
pipeline read here on a thread of its own. With ``[uav].annotate_http`` / ``annotate_video`` (detector
"pixels"), what the UAV sees is drawn with its detections and the localizer's crowds and served as
MJPEG / written to a video file (:mod:`.view`)."""

from __future__ import annotations

import logging

from uvteam import keys
from uvteam.config import VehicleConfig
from uvteam.errors import ConfigError
from uvteam.frames import FrameError
from uvteam.io.annotated import MjpegServer, VideoFileWriter
from uvteam.io.files import read_signing_key
from uvteam.io.mavlink import AutopilotLink
from uvteam.io.video import open_source
from uvteam.messages import Crowds, Fix
from uvteam.nodes.uav import UavNode
from uvteam.service import StopFlag, run_node

from .view import AnnotatedView

log = logging.getLogger("uvteam.uav")


def open_view(cfg: VehicleConfig) -> AnnotatedView | None:
    """The annotated view the config asks for (None: none), its HTTP server listening."""
    u = cfg.uav
    if not (u.annotate_http or u.annotate_video):
        return None
    if u.detector != "pixels":
        log.warning("uav.annotate_http / annotate_video need detector \"pixels\" (there are no frames to draw on)")
        return None
    server = None
    if u.annotate_http:
        host, _, port = u.annotate_http.rpartition(":")
        host = host.strip("[]")
        try:
            server = MjpegServer((host, int(port)), title=f"{cfg.team}/{cfg.id}: what the UAV sees").start()
        except OSError as exc:
            raise ConfigError(cfg.source, "uav.annotate_http", f"cannot serve on {u.annotate_http}: {exc}") from None
        log.info("what the UAV sees: %s (MJPEG: %sstream.mjpg)", server.url, server.url)
    writer = VideoFileWriter(u.annotate_video) if u.annotate_video else None
    return AnnotatedView(cfg.id, server, writer)


def run(cfg: VehicleConfig, stop: StopFlag) -> int:
    u = cfg.uav
    source = None
    if u.detector == "pixels" and u.camera != "zenoh":
        try:
            source = open_source(u.camera)
        except FrameError as exc:
            raise ConfigError(cfg.source, "uav.camera", str(exc)) from exc
    link = AutopilotLink(cfg.autopilot.url, target_system=cfg.autopilot.system_id,
                         target_component=cfg.autopilot.component_id, signing_key=read_signing_key(cfg),
                         link_timeout_s=cfg.autopilot.link_timeout_s, cancel=stop)
    view = open_view(cfg)

    def make_node(bus) -> UavNode:
        node = UavNode(cfg, bus, link)
        if view is not None:
            node.on_processed = view.on_processed
            bus.subscribe(keys.all_vehicles(cfg.team, "crowds"), Crowds, view.on_crowds)
            bus.subscribe(keys.all_vehicles(cfg.team, "fix"), Fix, view.on_fix)
        return node

    def shell_workers(node: UavNode):
        loops = [("annotate", view.worker)] if view is not None else []

        def grab(stop_: StopFlag) -> None:
            for seq, (stamp, img) in enumerate(source.stream(stop_), start=1):
                node.put_frame(stamp, seq, img)
            if not stop_.is_set():
                log.warning("camera %s: no more frames", u.camera)
        return loops + ([("camera", grab)] if source is not None else [])

    try:
        with link:
            return run_node(cfg, stop, make_node, shell_workers)
    finally:
        if source is not None:
            source.close()
        if view is not None:
            if view.server is not None:
                view.server.close()
            if view.writer is not None:
                view.writer.close()
                log.info("annotated video: %d frames at %.1f fps in %s", view.writer.frames, view.writer.fps,
                         view.writer.path)
