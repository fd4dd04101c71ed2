"""The UAV service shell: the MAVLink link, the camera and the zenoh bus around
:class:`uvteam.nodes.uav.UavNode`. Frames come from ``[uav].camera``: "zenoh" (the ``.../frame`` key,
which the simulator feeds; the node subscribes itself), or a device, file, RTSP URL or GStreamer
pipeline read here on a thread of its own."""

from __future__ import annotations

import logging

from uvteam.config import VehicleConfig
from uvteam.errors import ConfigError
from uvteam.frames import FrameError
from uvteam.io.files import read_signing_key
from uvteam.io.mavlink import AutopilotLink
from uvteam.io.video import open_source
from uvteam.nodes.uav import UavNode
from uvteam.service import StopFlag, run_node

log = logging.getLogger("uvteam.uav")


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
                         link_timeout_s=cfg.autopilot.link_timeout_s)

    def camera(node: UavNode):
        def grab(stop_: StopFlag) -> None:
            for seq, (stamp, img) in enumerate(source.stream(stop_), start=1):
                node.put_frame(stamp, seq, img)
            if not stop_.is_set():
                log.warning("camera %s: no more frames", u.camera)
        return [("camera", grab)] if source is not None else []

    try:
        with link:
            return run_node(cfg, stop, lambda bus: UavNode(cfg, bus, link), camera)
    finally:
        if source is not None:
            source.close()
