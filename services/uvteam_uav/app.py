"""The UAV service shell: autopilot -> its fix; detector -> detections (colour landmarks + motion blobs).

Detectors: "sim-sensor" takes the simulator's sensor-model output (``uvteam/<team>/<uav>/sensor``,
landmarks labelled by roof colour) and maps colours to UGV ids with ``[uav].colors``.
"""

from __future__ import annotations

import logging
import time
from dataclasses import replace

from uvteam import keys
from uvteam.autopilot import AutopilotLink, fix_from_state
from uvteam.bus import ZenohBus
from uvteam.config import VehicleConfig, read_signing_key
from uvteam.errors import ConfigError
from uvteam.messages import Detections, Landmark, Status
from uvteam.service import StopFlag

log = logging.getLogger("uvteam.uav")


def relabel(det: Detections, vehicle: str, colors: dict[str, str]) -> Detections:
    """Colour names -> UGV ids; colours not in the table are dropped (not our team's)."""
    lms = tuple(Landmark(colors[lm.ugv], lm.x_px, lm.y_px) for lm in det.landmarks if lm.ugv in colors)
    blobs = tuple(replace(b, ugv=colors.get(b.ugv, "")) for b in det.blobs)
    return replace(det, vehicle=vehicle, landmarks=lms, blobs=blobs)


def run(cfg: VehicleConfig, stop: StopFlag) -> int:
    if cfg.uav.detector not in ("sim-sensor",):
        raise ConfigError(cfg.source, "uav.detector", f"unknown detector {cfg.uav.detector!r} (this build: sim-sensor)")
    link = AutopilotLink(cfg.autopilot.url, target_system=cfg.autopilot.system_id,
                         target_component=cfg.autopilot.component_id, signing_key=read_signing_key(cfg),
                         link_timeout_s=cfg.autopilot.link_timeout_s)
    counts = {"frames": 0}
    with ZenohBus.open(cfg.bus) as bus, link:
        bus.declare_alive(keys.alive(cfg.team, cfg.id))
        det_key = keys.key(cfg.team, cfg.id, "detections")

        def on_sensor(key: str, det: Detections) -> None:
            bus.publish(det_key, relabel(det, cfg.id, cfg.uav.colors))
            counts["frames"] += 1

        bus.subscribe(keys.key(cfg.team, cfg.id, "sensor"), Detections, on_sensor)
        log.info("UAV %s up: detector %s, autopilot %s", cfg.id, cfg.uav.detector, cfg.autopilot.url)
        last = 0.0
        next_status = 0.0
        while not stop.wait(0.02):
            st = link.state()
            if st is not None and st.stamp_s > last:
                last = st.stamp_s
                bus.publish(keys.key(cfg.team, cfg.id, "fix"), fix_from_state(cfg.id, st))
            now = time.time()
            if now >= next_status:
                bus.publish(keys.key(cfg.team, cfg.id, "status"),
                            Status(cfg.id, "uav", now, link.link_state, bus.rejected_total, bus.published,
                                   bus.received, f"frames={counts['frames']}"))
                next_status = now + 1.0
    return 0
