"""The UAV service's logic: its autopilot -> its fix; camera frames -> detector -> detections.

Detectors (``[uav].detector``, :data:`uvteam.vocab.DETECTORS`):
- "pixels": frames (the shell's camera, file or stream, or the ``.../frame`` key the simulator feeds)
  through :class:`uvteam.vision.uav.UavVision` (roof labels + motion blobs), sized by the autopilot's
  height above ground. Frames are processed newest first: one that arrives while the previous is still
  in work replaces any waiting one (``dropped``). The detections declare the pipeline's noise at this
  camera and height (:func:`uvteam.detector_noise.pixel_pipeline_noise`).
- "sim-sensor": the simulator's sensor-model detections (``.../sensor``), relabelled and passed on.
Roof colors are mapped to UGV ids with ``[uav].colors``; colors not in the table are not our team's.

The camera's pose (:meth:`UavNode.pose_report`: the autopilot's position, height, heading and, with a
fixed mount, attitude; the mounting and the sigmas from ``[uav]``) goes with every frame's detections.
With the team's fixes (subscribed) it also tells the vision where each UGV's roof label must be
(:meth:`UavNode.expectations`): a label-colored patch on the ground elsewhere is never taken for a UGV;
why a color's blobs were refused is counted in the status (``labels_refused_<why>``). Frames the motion
detector returns no crowd's blob for while its history (re)starts are counted as ``motion_warming``
(a few after the first frame, and after each lost camera registration: :mod:`uvteam.vision.motion`).
"""

from __future__ import annotations

import logging
import math
import time
from collections import deque
from collections.abc import Callable
from dataclasses import replace

import numpy as np

from .. import keys
from ..autopilot import Autopilot, fix_from_state
from ..bus import Bus, RateLimitedLog
from ..camera import PinholeCamera
from ..config import VehicleConfig
from ..detector_noise import pixel_pipeline_noise
from ..frames import FrameError, frame_pixels
from ..geo import LocalFrame
from ..messages import CameraPoseReport, Detections, Fix, Frame
from ..pose import pose_prior
from ..sync import LatestSlot, StopFlag
from ..vision.uav import LabelExpectation, UavVision, UavVisionConfig
from . import STREAM_START_S, Counts, sender_ok

__all__ = ["UavNode", "MIN_ALT_AGL_M"]

log = logging.getLogger("uvteam.uav")
MIN_ALT_AGL_M = 1.0        # below this the autopilot's height above ground is not one to size blobs by
FIX_FRESH_S = 2.0          # a UGV fix older than this predicts nothing
MOVING_M_S = 0.5           # a UGV reporting more than this moves: its label rides on motion
PREDICTION_SIGMAS = 3.0
FIX_HISTORY = 30           # fixes kept per UGV
VELOCITY_SPAN_S = (0.3, 1.5)   # a velocity from fixes this far apart when the receiver gives none
VELOCITY_FRESH_S = 0.3     # a fix older than this (or 1.5 fix intervals of its UGV, if longer) says where a
                           # UGV may be, not how it moves now (a UGV on station turns up to ~100 deg/s: a 0.5 s
                           # old velocity at 10 Hz refuted its own label)
DEFAULT_POSITION_SIGMA_M = 2.0


class UavNode:
    service = "uav"

    def __init__(self, cfg: VehicleConfig, bus: Bus, autopilot: Autopilot, clock: Callable[[], float] = time.time) -> None:
        self.cfg, self.bus, self.autopilot, self.clock = cfg, bus, autopilot, clock
        self.u = cfg.uav
        self.frames = LatestSlot()
        self.vision: UavVision | None = None
        self.size: tuple[int, int] | None = None
        self.last_state_stamp = 0.0
        self.first_frame_s: float | None = None
        self.det_key = keys.key(cfg.team, cfg.id, "detections")
        self.counts = Counts("frames", "processed", "no_altitude", "bad_frames", "fixes_published", "no_pose")
        self.refusals = Counts()
        self.frame_en: LocalFrame | None = None
        self.ugv_fix: dict[str, Fix] = {}
        self.ugv_fixes: dict[str, deque[Fix]] = {}   # the recent ones, for a velocity the receiver does not give
        self.ugv_of_color = dict(self.u.colors)
        self.vision_ms: deque[float] = deque(maxlen=500)
        self._warn = RateLimitedLog(log)
        # the shell's view of each processed frame (the annotated video): called on the vision thread, keep it short
        self.on_processed: Callable[[np.ndarray, Detections], None] | None = None

    def start(self) -> None:
        self.bus.subscribe(keys.all_vehicles(self.cfg.team, "fix"), Fix, self.on_fix)
        if self.u.detector == "sim-sensor":
            self.bus.subscribe(keys.key(self.cfg.team, self.cfg.id, "sensor"), Detections, self.on_sensor)
        elif self.u.camera == "zenoh":
            self.bus.subscribe(keys.key(self.cfg.team, self.cfg.id, "frame"), Frame, self.on_frame)

    # --- inputs ----------------------------------------------------------------------------------------
    def on_fix(self, key: str, fix: Fix) -> None:
        """The team's UGV fixes: where each roof label must be."""
        if fix.vehicle not in self.ugv_of_color.values():
            return
        if not sender_ok(key, fix.vehicle):
            self.bus.reject(key, f"a fix for {fix.vehicle} under another vehicle's key")
            return
        old = self.ugv_fix.get(fix.vehicle)
        if old is None or fix.stamp_s > old.stamp_s:
            self.ugv_fix[fix.vehicle] = fix
            self.ugv_fixes.setdefault(fix.vehicle, deque(maxlen=FIX_HISTORY)).append(fix)

    def on_sensor(self, key: str, det: Detections) -> None:
        """The sensor model's detections (by roof color) -> this UAV's detections (by UGV id)."""
        if not sender_ok(key, det.vehicle, self.cfg.id):
            self.bus.reject(key, f"sensor detections for {det.vehicle} under another vehicle's key")
            return
        self.counts.add("frames")
        st = self.autopilot.state()
        pose = self.pose_report(st) if st is not None else None
        self.bus.publish(self.det_key, replace(det, vehicle=self.cfg.id, landmarks=det.landmarks.relabel(self.u.colors),
                                               blobs=det.blobs.relabel(self.u.colors), pose=pose))
        self.counts.add("processed")

    def on_frame(self, key: str, fr: Frame) -> None:
        if not sender_ok(key, fr.vehicle, self.cfg.id):
            self.bus.reject(key, f"a frame for {fr.vehicle} under another vehicle's key")
            return
        self.put_frame(fr.stamp_s, fr.frame_seq, fr)

    def put_frame(self, stamp_s: float, seq: int, frame) -> None:
        """A frame (an image, or a :class:`Frame` message still encoded) for the vision worker."""
        self.counts.add("frames")
        self.frames.put((stamp_s, seq, frame))

    # --- phases ---------------------------------------------------------------------------------------
    def publish_fix(self) -> None:
        st = self.autopilot.state()
        if st is None or st.stamp_s <= self.last_state_stamp:
            return
        self.last_state_stamp = st.stamp_s
        self.bus.publish(keys.key(self.cfg.team, self.cfg.id, "fix"), fix_from_state(self.cfg.id, st))
        self.counts.add("fixes_published")

    def pose_report(self, st) -> CameraPoseReport | None:
        """The camera's pose from the autopilot's state and the mounting (None without a heading)."""
        heading = st.yaw_deg if st.yaw_deg is not None else st.heading_deg
        if heading is None or not math.isfinite(st.alt_agl_m):
            return None
        u = self.u
        roll, pitch = u.mount_roll_deg, u.mount_pitch_deg
        if u.gimbal == "fixed":   # the camera tilts with the body
            roll, pitch = roll + (st.roll_deg or 0.0), pitch + (st.pitch_deg or 0.0)
        pos = u.position_sigma_m or (st.h_acc_m if st.h_acc_m is not None else DEFAULT_POSITION_SIGMA_M)
        return CameraPoseReport(st.lat_deg, st.lon_deg, max(st.alt_agl_m, 0.0), max(-90.0, min(90.0, roll)),
                                max(-90.0, min(90.0, pitch)), (heading + u.mount_yaw_deg) % 360.0, pos,
                                u.attitude_sigma_deg, u.heading_sigma_deg, u.alt_sigma_m)

    def expectations(self, report: CameraPoseReport | None, now_s: float, w: int, h: int,
                     focal_px: float) -> dict[str, LabelExpectation]:
        """Where each UGV's roof label must be in this frame: its fresh fix through the camera's pose,
        within 3 sigma of the pose, the fix and the distance the UGV covered since its fix."""
        if report is None:
            return {}
        if self.frame_en is None:
            self.frame_en = LocalFrame(report.lat_deg, report.lon_deg)
        prior = pose_prior(report, self.frame_en, w, h, focal_px)
        if prior is None:
            return {}
        px_per_m = focal_px / max(report.alt_agl_m, MIN_ALT_AGL_M)
        out = {}
        for color, ugv in self.ugv_of_color.items():
            f = self.ugv_fix.get(ugv)
            if f is None or not 0.0 <= now_s - f.stamp_s <= FIX_FRESH_S:
                continue
            en = np.array([self.frame_en.wgs84_to_ground(f.lat_deg, f.lon_deg)], float)
            v = self.ugv_velocity(ugv)
            speed = math.hypot(*v) if v is not None else 0.0
            sigma = math.sqrt(float(prior.sigma_m(en)[0]) ** 2 + f.h_acc_m ** 2 + (speed * (now_s - f.stamp_s)) ** 2)
            xy = prior.ground_to_px(np.vstack([en, en + (v if v is not None else 0.0)]))
            if np.isfinite(xy).all():
                out[color] = LabelExpectation((float(xy[0, 0]), float(xy[0, 1])),
                                              max(PREDICTION_SIGMAS * sigma, 2.0 * self.u.label_side_m) * px_per_m,
                                              speed > MOVING_M_S,
                                              None if v is None or now_s - f.stamp_s > self.velocity_fresh_s(ugv)
                                              else (float(xy[1, 0] - xy[0, 0]), float(xy[1, 1] - xy[0, 1])),
                                              f.stamp_s)
        return out

    def velocity_fresh_s(self, ugv: str) -> float:
        """How long a UGV's fix tells how it moves: 0.3 s, or 1.5 of its fix intervals (median) if longer."""
        t = [f.stamp_s for f in self.ugv_fixes.get(ugv, ())]
        return max(VELOCITY_FRESH_S, 1.5 * float(np.median(np.diff(t)))) if len(t) >= 2 else VELOCITY_FRESH_S

    def ugv_velocity(self, ugv: str) -> np.ndarray | None:
        """(east, north) m/s: the UGV's receiver's, else from its fixes over the last 0.3-1.5 s, else None."""
        f = self.ugv_fix[ugv]
        if f.v_east_m_s is not None:
            return np.array([f.v_east_m_s, f.v_north_m_s], float)
        lo, hi = VELOCITY_SPAN_S
        for g in self.ugv_fixes.get(ugv, ()):   # oldest first
            if lo <= f.stamp_s - g.stamp_s <= hi:
                a = np.array(self.frame_en.wgs84_to_ground(g.lat_deg, g.lon_deg), float)
                b = np.array(self.frame_en.wgs84_to_ground(f.lat_deg, f.lon_deg), float)
                return (b - a) / (f.stamp_s - g.stamp_s)
        return None

    def process_frame(self, stamp_s: float, seq: int, img: np.ndarray) -> Detections | None:
        """One image through the vision pipeline at the autopilot's height above ground -> detections."""
        st = self.autopilot.state()
        if self.first_frame_s is None:
            self.first_frame_s = stamp_s
        if st is None or not (math.isfinite(st.alt_agl_m) and st.alt_agl_m > MIN_ALT_AGL_M):
            self.counts.add("no_altitude")
            if st is None and stamp_s - self.first_frame_s < STREAM_START_S:
                log.debug("frame %d not processed: the autopilot's stream is starting", seq)
            else:
                self._warn.warn("altitude", "frame %d not processed: no height above ground from the autopilot yet",
                                seq)
            return None
        h, w = img.shape[:2]
        if (w, h) != self.size:   # the focal length in pixels follows the frame size
            self.size = (w, h)
            self.vision = UavVision(UavVisionConfig(focal_px=PinholeCamera(w, h, self.u.hfov_deg).focal_px,
                                                    colors=tuple(self.u.colors), label_side_m=self.u.label_side_m))
        focal = self.vision.cfg.focal_px
        report = self.pose_report(st)
        if report is None:
            self.counts.add("no_pose")
        t0 = time.perf_counter()
        r = self.vision.update(img, stamp_s, st.alt_agl_m, self.expectations(report, stamp_s, w, h, focal))
        self.vision_ms.append((time.perf_counter() - t0) * 1e3)
        for why in r.refused.values():
            self.refusals.add(why)
        if r.warming:     # no crowd's blob: the motion detector (re)starting its history
            self.counts.add("motion_warming")
        noise = pixel_pipeline_noise(st.alt_agl_m, focal)
        det = Detections(self.cfg.id, stamp_s, seq, w, h, st.alt_agl_m, focal,
                         r.landmarks.relabel(self.u.colors), r.blobs.relabel(self.u.colors),
                         noise.color_px, noise.ugv_blob_px, noise.crowd_blob_px, report, noise.crowd_blob_frame_px)
        self.bus.publish(self.det_key, det)
        self.counts.add("processed")
        if self.on_processed is not None:
            self.on_processed(img, det)
        return det

    def vision_step(self, timeout_s: float) -> Detections | None:
        item = self.frames.take(timeout_s)
        if item is None:
            return None
        stamp, seq, payload = item
        try:
            img = frame_pixels(payload) if isinstance(payload, Frame) else payload
        except FrameError as exc:
            self.counts.add("bad_frames")
            self._warn.warn("frame", "frame %d dropped: %s", seq, exc)
            return None
        return self.process_frame(stamp, seq, img)

    # --- the service loop's interface ---------------------------------------------------------------
    def step(self, timeout_s: float) -> None:
        self.publish_fix()
        if timeout_s > 0:
            time.sleep(timeout_s)

    def workers(self) -> list[tuple[str, Callable[[StopFlag], None]]]:
        if self.u.detector != "pixels":
            return []

        def vision(stop: StopFlag) -> None:
            while not stop.is_set():
                self.vision_step(0.2)
        return [("vision", vision)]

    def metrics(self) -> dict[str, float]:
        out = {**self.counts.as_dict(), "dropped": float(self.frames.dropped)}
        out.update({f"labels_refused_{k}": v for k, v in self.refusals.as_dict().items()})
        if self.vision_ms:
            out["vision_ms_p50"] = float(np.median(self.vision_ms))
        return out

    def link_state(self) -> str:
        return self.autopilot.link_state

    def note(self) -> str:
        return f"detector {self.u.detector}, camera {self.u.camera if self.u.detector == 'pixels' else '-'}"
