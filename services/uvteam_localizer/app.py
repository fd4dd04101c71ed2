"""The localizer service shell: UAV detections + UGV fixes and plans -> geolocated crowds for the team.

Per detections message: the core step (uvteam.localizer.localize_step), the crowd tracker, and a
Crowds message with every confirmed crowd (seen in ``confirm_hits`` frames) on
``uvteam/<team>/<uav>/crowds``. A UGV whose liveliness token goes away is dropped at once; one whose
fixes stop is covered by its plan for one tracking interval, then dropped (the core's rule).
"""

from __future__ import annotations

import logging
import math
import queue
import threading
import time
from collections import deque

import numpy as np

from uvteam import keys
from uvteam.io.zenoh_bus import ZenohBus
from uvteam.config import VehicleConfig
from uvteam.crowds import GroupingConfig, GroupingState, report_crowds
from uvteam.geo import LocalFrame
from uvteam.localizer import FrameObservation, LocalizerConfig, LocalizerState, UgvTrack, localize_step
from uvteam.messages import Crowd, Crowds, Detections, Fix, Plan, Status
from uvteam.service import StopFlag

log = logging.getLogger("uvteam.localizer")


class LocalizerService:
    def __init__(self, cfg: VehicleConfig) -> None:
        self.cfg = cfg
        self.lc = cfg.localizer
        self.frame: LocalFrame | None = None
        if math.isfinite(self.lc.origin_lat_deg) and math.isfinite(self.lc.origin_lon_deg):
            self.frame = LocalFrame(self.lc.origin_lat_deg, self.lc.origin_lon_deg)
        self.fixes: dict[str, deque] = {}
        self.plans: dict[str, Plan] = {}
        self.dead: set[str] = set()
        self._lock = threading.Lock()
        self.frames: queue.Queue = queue.Queue(maxsize=8)
        self.state = LocalizerState()
        self.grouping = GroupingState()
        self.published = 0
        self.step_us: deque = deque(maxlen=1000)
        self.last_quality = "none"
        self.dropped_frames = 0

    def is_ugv(self, vehicle: str) -> bool:
        return vehicle in self.lc.ugvs if self.lc.ugvs else vehicle != self.lc.uav

    # zenoh threads
    def on_fix(self, key: str, fix: Fix) -> None:
        if not self.is_ugv(fix.vehicle):
            return
        with self._lock:
            if self.frame is None:
                self.frame = LocalFrame(fix.lat_deg, fix.lon_deg)
                log.info("local frame origin from %s's first fix: %.7f, %.7f", fix.vehicle, fix.lat_deg, fix.lon_deg)
            d = self.fixes.setdefault(fix.vehicle, deque(maxlen=64))
            if d and fix.stamp_s <= d[-1].stamp_s:
                return  # out of order or repeated
            d.append(fix)
            self.dead.discard(fix.vehicle)

    def on_plan(self, key: str, plan: Plan) -> None:
        if self.is_ugv(plan.vehicle):
            with self._lock:
                self.plans[plan.vehicle] = plan

    def on_alive(self, key: str, alive: bool) -> None:
        v = keys.vehicle_of(key)
        if v is None or not self.is_ugv(v):
            return
        with self._lock:
            if alive:
                self.dead.discard(v)
            else:
                self.dead.add(v)
                self.fixes.pop(v, None)
                self.plans.pop(v, None)
        log.warning("UGV %s %s", v, "is alive" if alive else "lost (liveliness): no longer a landmark")

    def on_detections(self, key: str, det: Detections) -> None:
        if det.vehicle != self.lc.uav:
            return
        try:
            self.frames.put_nowait(det)
        except queue.Full:  # never fall behind: the newest frame wins
            try:
                self.frames.get_nowait()
                self.dropped_frames += 1
            except queue.Empty:
                pass
            self.frames.put_nowait(det)

    # main thread
    def tracks(self) -> dict[str, UgvTrack]:
        with self._lock:
            fixes = {v: list(d) for v, d in self.fixes.items() if v not in self.dead and d}
            plans = {v: p for v, p in self.plans.items() if v not in self.dead}
        out = {}
        for v, fl in fixes.items():
            st = np.array([f.stamp_s for f in fl])
            e, n = self.frame.wgs84_to_ground(np.array([f.lat_deg for f in fl]), np.array([f.lon_deg for f in fl]))
            sg = np.array([f.h_acc_m for f in fl])
            vel = np.array([[f.v_east_m_s, f.v_north_m_s] for f in fl])
            p = plans.get(v)
            if p is not None and p.waypoints:
                ps = np.array([w.stamp_s for w in p.waypoints])
                pe, pn = self.frame.wgs84_to_ground(np.array([w.lat_deg for w in p.waypoints]),
                                                    np.array([w.lon_deg for w in p.waypoints]))
                pen = np.column_stack([pe, pn])
                # the plan starts where the UGV was when it was made
                ps, pen = np.concatenate([[p.stamp_s], ps]), np.vstack([[e[-1], n[-1]], pen])
            else:
                ps, pen = np.empty(0), np.empty((0, 2))
            out[v] = UgvTrack(st, np.column_stack([e, n]), sg, ps, pen, vel)
        return out

    def step(self, det: Detections) -> Crowds | None:
        if self.frame is None:
            return None
        t0 = time.perf_counter()
        lc = self.lc
        cfg = LocalizerConfig(frame=self.frame, gate_px=lc.gate_px, tracking_interval_s=lc.tracking_interval_s,
                              image_coordinates=lc.image_coordinates, solver=lc.solver, hold_max_s=lc.hold_max_s,
                              sigma_landmark_px=lc.sigma_landmark_px, sigma_target_px=lc.sigma_target_px)
        blobs = np.array([[b.x_px, b.y_px] for b in det.blobs]).reshape(-1, 2)
        boxes = np.array([[b.x0_px, b.y0_px, b.x1_px, b.y1_px] for b in det.blobs]).reshape(-1, 4)
        obs = FrameObservation(det.stamp_s, {lm.ugv: (lm.x_px, lm.y_px) for lm in det.landmarks}, blobs, boxes,
                               tuple(b.ugv for b in det.blobs), np.array([b.area_px for b in det.blobs]))
        self.state, res = localize_step(self.state, obs, self.tracks(), cfg)
        # the longest-seen crowd first: a UGV that follows one crowd follows that one
        self.grouping, reported = report_crowds(self.grouping, res.crowds, det.stamp_s, self.frame,
                                               GroupingConfig(confirm_hits=lc.confirm_hits))
        out = []
        for c, tr in reported:
            out.append(Crowd(tr.track_id, c.lat_deg, c.lon_deg, tuple(map(float, c.footprint_latlon_deg[:, 0])),
                             tuple(map(float, c.footprint_latlon_deg[:, 1])), tr.v_east_m_s, tr.v_north_m_s,
                             c.radius95_m, c.quality.value, c.n_outliers))
        self.step_us.append((time.perf_counter() - t0) * 1e6)
        self.last_quality = res.quality.value
        return Crowds(self.cfg.id, det.stamp_s, res.quality.value, res.landmarks_used, res.outlier_landmarks, tuple(out))


def run(cfg: VehicleConfig, stop: StopFlag) -> int:
    svc = LocalizerService(cfg)
    with ZenohBus.open(cfg.bus) as bus:
        bus.declare_alive(keys.alive(cfg.team, cfg.id))
        bus.subscribe(keys.all_vehicles(cfg.team, "fix"), Fix, svc.on_fix)
        bus.subscribe(keys.all_vehicles(cfg.team, "plan"), Plan, svc.on_plan)
        bus.subscribe(keys.key(cfg.team, cfg.localizer.uav, "detections"), Detections, svc.on_detections)
        bus.watch_alive(keys.alive_all(cfg.team), svc.on_alive)
        out_key = keys.key(cfg.team, cfg.localizer.uav, "crowds")
        log.info("localizer %s up for %s's detections", cfg.id, cfg.localizer.uav)
        next_status = 0.0
        while not stop.is_set():
            try:
                det = svc.frames.get(timeout=0.1)
            except queue.Empty:
                det = None
            if det is not None:
                msg = svc.step(det)
                if msg is not None:
                    bus.publish(out_key, msg)
                    svc.published += 1
            now = time.time()
            if now >= next_status:
                us = np.array(svc.step_us) if svc.step_us else np.zeros(1)
                bus.publish(keys.key(cfg.team, cfg.id, "status"), Status(
                    cfg.id, "localizer", now, "none", bus.rejected_total, bus.published, bus.received,
                    f"crowds_published={svc.published} quality={svc.last_quality} step_us_p50={np.median(us):.0f} "
                    f"dropped_frames={svc.dropped_frames} landmarks_dead={','.join(sorted(svc.dead)) or '-'}"))
                next_status = now + 1.0
    return 0
