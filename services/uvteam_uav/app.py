"""The UAV service shell: autopilot -> its fix; camera frames -> detector -> detections.

Detectors (``[uav].detector``):
- "pixels": frames from ``[uav].camera`` ("zenoh": the ``.../frame`` key, which the simulator feeds;
  or a device, file, RTSP URL or GStreamer pipeline) through :class:`uvteam.vision.uav.UavVision`
  (color landmarks + motion blobs), sized by the autopilot's height above ground. Frames are processed
  newest first: one that arrives while the previous is still in work replaces any waiting one, and the
  dropped count is in the status note.
- "sim-sensor": the simulator's sensor-model output (``.../sensor``), for runs without pixels.
Roof colors are mapped to UGV ids with ``[uav].colors``; colors not in the table are not our team's.
"""

from __future__ import annotations

import logging
import math
import threading
import time
from dataclasses import replace

from uvteam import keys
from uvteam.autopilot import fix_from_state
from uvteam.io.mavlink import AutopilotLink
from uvteam.io.zenoh_bus import ZenohBus
from uvteam.camera import PinholeCamera
from uvteam.config import VehicleConfig
from uvteam.io.files import read_signing_key
from uvteam.errors import ConfigError
from uvteam.frames import FrameError, frame_pixels
from uvteam.io.video import open_source
from uvteam.messages import Blob, Detections, Frame, Landmark, Status
from uvteam.service import StopFlag
from uvteam.vision.uav import UavFrameResult, UavVision, UavVisionConfig

log = logging.getLogger("uvteam.uav")
DETECTORS = ("pixels", "sim-sensor")


def relabel(det: Detections, vehicle: str, colors: dict[str, str]) -> Detections:
    """Color names -> UGV ids; colors not in the table are dropped (not our team's)."""
    lms = tuple(Landmark(colors[lm.ugv], lm.x_px, lm.y_px) for lm in det.landmarks if lm.ugv in colors)
    blobs = tuple(replace(b, ugv=colors.get(b.ugv, "")) for b in det.blobs)
    return replace(det, vehicle=vehicle, landmarks=lms, blobs=blobs)


def detections_from(r: UavFrameResult, vehicle: str, seq: int, width_px: int, height_px: int, alt_agl_m: float,
                    colors: dict[str, str]) -> Detections:
    """A pixel-pipeline result -> the Detections message (colors as UGV ids)."""
    b = r.blobs
    blobs = tuple(Blob(float(c[0]), float(c[1]), *map(float, box), ugv=colors.get(col, ""), area_px=float(a))
                  for c, box, col, a in zip(b.xy_px, b.xyxy_px, r.blob_color, b.area_px))
    lms = tuple(Landmark(colors[c], float(x), float(y)) for c, (x, y) in r.landmarks_px.items() if c in colors)
    return Detections(vehicle, r.stamp_s, seq, width_px, height_px, alt_agl_m, lms, blobs)


class LatestSlot:
    """One waiting item; a newer one replaces it (counted as dropped)."""

    def __init__(self) -> None:
        self._cv = threading.Condition()
        self._item = None
        self.dropped = 0

    def put(self, item) -> None:
        with self._cv:
            if self._item is not None:
                self.dropped += 1
            self._item = item
            self._cv.notify()

    def take(self, timeout_s: float):
        with self._cv:
            if self._item is None:
                self._cv.wait(timeout_s)
            item, self._item = self._item, None
            return item


def run(cfg: VehicleConfig, stop: StopFlag) -> int:
    u = cfg.uav
    if u.detector not in DETECTORS:
        raise ConfigError(cfg.source, "uav.detector", f"unknown detector {u.detector!r}; known: {', '.join(DETECTORS)}")
    link = AutopilotLink(cfg.autopilot.url, target_system=cfg.autopilot.system_id,
                         target_component=cfg.autopilot.component_id, signing_key=read_signing_key(cfg),
                         link_timeout_s=cfg.autopilot.link_timeout_s)
    counts = {"frames": 0, "processed": 0, "no_altitude": 0, "bad_frames": 0}
    slot = LatestSlot()
    source = None
    if u.detector == "pixels" and u.camera != "zenoh":
        try:
            source = open_source(u.camera)
        except FrameError as exc:
            raise ConfigError(cfg.source, "uav.camera", str(exc)) from exc
    with ZenohBus.open(cfg.bus) as bus, link:
        bus.declare_alive(keys.alive(cfg.team, cfg.id))
        det_key = keys.key(cfg.team, cfg.id, "detections")

        def on_sensor(key: str, det: Detections) -> None:
            bus.publish(det_key, relabel(det, cfg.id, u.colors))
            counts["frames"] += 1
            counts["processed"] += 1

        def on_frame(key: str, fr: Frame) -> None:
            counts["frames"] += 1
            slot.put((fr.stamp_s, fr.frame_seq, fr))

        def grab_loop() -> None:
            for seq, (stamp, img) in enumerate(source.stream(stop), start=1):
                counts["frames"] += 1
                slot.put((stamp, seq, img))
            if not stop.is_set():
                log.warning("camera %s: no more frames", u.camera)

        def work_loop() -> None:
            vision: UavVision | None = None
            size = None
            while not stop.is_set():
                item = slot.take(0.2)
                if item is None:
                    continue
                stamp, seq, payload = item
                try:
                    img = frame_pixels(payload) if isinstance(payload, Frame) else payload
                except FrameError as exc:
                    counts["bad_frames"] += 1
                    log.warning("frame %d dropped: %s", seq, exc)
                    continue
                st = link.state()
                if st is None or not (math.isfinite(st.alt_agl_m) and st.alt_agl_m > 1.0):
                    counts["no_altitude"] += 1
                    continue
                h, w = img.shape[:2]
                if (w, h) != size:   # the focal length in pixels follows the frame size
                    size = (w, h)
                    vision = UavVision(UavVisionConfig(focal_px=PinholeCamera(w, h, u.hfov_deg).focal_px,
                                                       colors=tuple(u.colors), label_side_m=u.label_side_m))
                r = vision.update(img, stamp, st.alt_agl_m)
                bus.publish(det_key, detections_from(r, cfg.id, seq, w, h, st.alt_agl_m, u.colors))
                counts["processed"] += 1

        threads = []
        if u.detector == "sim-sensor":
            bus.subscribe(keys.key(cfg.team, cfg.id, "sensor"), Detections, on_sensor)
        else:
            if source is None:
                bus.subscribe(keys.key(cfg.team, cfg.id, "frame"), Frame, on_frame)
            else:
                threads.append(threading.Thread(target=grab_loop, name="camera", daemon=True))
            threads.append(threading.Thread(target=work_loop, name="vision", daemon=True))
        for t in threads:
            t.start()
        log.info("UAV %s up: detector %s, camera %s, autopilot %s", cfg.id, u.detector,
                 u.camera if u.detector == "pixels" else "-", cfg.autopilot.url)
        last = 0.0
        next_status = 0.0
        try:
            while not stop.wait(0.02):
                st = link.state()
                if st is not None and st.stamp_s > last:
                    last = st.stamp_s
                    bus.publish(keys.key(cfg.team, cfg.id, "fix"), fix_from_state(cfg.id, st))
                now = time.time()
                if now >= next_status:
                    note = " ".join(f"{k}={v}" for k, v in counts.items()) + f" dropped={slot.dropped}"
                    bus.publish(keys.key(cfg.team, cfg.id, "status"),
                                Status(cfg.id, "uav", now, link.link_state, bus.rejected_total, bus.published,
                                       bus.received, note))
                    next_status = now + 1.0
        finally:
            stop.set()
            for t in threads:
                t.join(timeout=2.0)
            if source is not None:
                source.close()
            log.info("UAV %s stopping: %s dropped=%d", cfg.id, " ".join(f"{k}={v}" for k, v in counts.items()),
                     slot.dropped)
    return 0
