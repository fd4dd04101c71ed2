"""The UGV service shell: the MAVLink link, the forward camera and the zenoh bus around
:class:`uvteam.nodes.ugv.UgvNode`."""

from __future__ import annotations

import logging

from uvteam.config import VehicleConfig
from uvteam.errors import ConfigError
from uvteam.frames import FrameError
from uvteam.io.files import read_signing_key
from uvteam.io.mavlink import AutopilotLink
from uvteam.io.video import open_source
from uvteam.nodes.ugv import UgvNode
from uvteam.service import StopFlag, run_node

log = logging.getLogger("uvteam.ugv")


def run(cfg: VehicleConfig, stop: StopFlag) -> int:
    source = None
    if cfg.ugv.camera:
        try:
            source = open_source(cfg.ugv.camera)
        except FrameError as exc:
            raise ConfigError(cfg.source, "ugv.camera", str(exc)) from exc
    link = AutopilotLink(cfg.autopilot.url, target_system=cfg.autopilot.system_id,
                         target_component=cfg.autopilot.component_id, signing_key=read_signing_key(cfg),
                         link_timeout_s=cfg.autopilot.link_timeout_s, cancel=stop)

    detector = None
    if source is not None:
        from uvteam.vision.people import PeopleDetector  # noqa: PLC0415

        detector = PeopleDetector()

    def camera(node: UgvNode):
        def people(stop_: StopFlag) -> None:
            for stamp, img in source.stream(stop_):
                node.people_frame(stamp, img)
            if not stop_.is_set():
                log.warning("camera %s: no more frames", cfg.ugv.camera)
        return [("people", people)] if source is not None else []

    try:
        with link:
            return run_node(cfg, stop, lambda bus: UgvNode(cfg, bus, link, people_detector=detector), camera)
    finally:
        if source is not None:
            source.close()
