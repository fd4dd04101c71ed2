"""The UGV service shell: autopilot -> fix + plan on the bus; crowds -> planner -> mission -> autopilot;
with a forward camera (``[ugv].camera``), HOG people detection -> people geolocated by the triangle
rule (``uvteam.ugv_localize``) on ``.../people``.

Focal length for the triangle rule: the paper's calibration f = D*h/H from a person of ``person_height_m``
at ``camera_ref_distance_m`` whose detector box is ``camera_ref_box_height_px`` tall; without one, from
``camera_hfov_deg`` scaled by the HOG window's height over the person's in it (128/96), since the rule
uses the box's height.
"""

from __future__ import annotations

import logging
import queue
import threading
import time

import numpy as np

from uvteam import keys
from uvteam.autopilot import fix_from_state
from uvteam.io.mavlink import AutopilotLink
from uvteam.io.zenoh_bus import ZenohBus
from uvteam.config import VehicleConfig
from uvteam.io.files import read_signing_key
from uvteam.errors import ConfigError, LinkError
from uvteam.geo import LocalFrame
from uvteam.camera import PinholeCamera
from uvteam.frames import FrameError
from uvteam.io.video import open_source
from uvteam.messages import Crowds, Fix, PeopleSeen, Person, Status
from uvteam.ugv_localize import focal_px_from_reference, localize_people
from uvteam.vision.people import PeopleDetector
from uvteam.planning import plan_stations
from uvteam.service import StopFlag

from uvteam.mission import mission_to_plan, plan_to_mission

log = logging.getLogger("uvteam.ugv")
HOG_BOX_OVER_PERSON = 128.0 / 96.0   # OpenCV's people window is 128 px tall around a ~96 px person


class UgvService:
    def __init__(self, cfg: VehicleConfig, bus, link: AutopilotLink) -> None:
        self.cfg, self.bus, self.link = cfg, bus, link
        self.frame: LocalFrame | None = None
        self.team_fix: dict[str, Fix] = {}
        self.crowd: tuple[np.ndarray, np.ndarray, float] | None = None   # en, v, stamp
        self.crowds_received = 0
        self.latency_ms: list[float] = []
        self._lock = threading.Lock()
        self._missions: queue.Queue = queue.Queue(maxsize=1)
        self.last_fix_stamp = 0.0
        self.published_plans = 0
        self.people_frames = 0
        self.people_seen = 0

    def focal_px(self, width_px: int, height_px: int) -> float:
        u = self.cfg.ugv
        if u.camera_ref_distance_m > 0 and u.camera_ref_box_height_px > 0:
            return focal_px_from_reference(u.camera_ref_distance_m, u.camera_ref_box_height_px, u.person_height_m)
        return PinholeCamera(width_px, height_px, u.camera_hfov_deg).focal_px * HOG_BOX_OVER_PERSON

    def people_loop(self, stop: StopFlag, source) -> None:
        """Frames -> HOG people -> geolocated with this UGV's newest fix and heading -> the bus."""
        det = PeopleDetector()
        u = self.cfg.ugv
        period = 1.0 / u.people_rate_hz if u.people_rate_hz > 0 else 0.0
        next_t = 0.0
        for stamp, img in source.stream(stop):
            if time.monotonic() < next_t:
                continue
            next_t = time.monotonic() + period
            st = self.link.state()
            if st is None or self.frame is None:
                continue
            found = det.detect(img)
            h, w = img.shape[:2]
            pf = localize_people(self.frame, st.lat_deg, st.lon_deg, ((st.heading_deg or 0.0) + u.camera_yaw_deg) % 360.0,
                                 self.focal_px(w, h), w / 2.0, found.feet_xy_px[:, 0], found.height_px, u.person_height_m)
            people = tuple(Person(float(la), float(lo), float(d), float(b))
                           for la, lo, d, b in zip(pf.lat_deg, pf.lon_deg, pf.distance_m, pf.bearing_deg))
            self.bus.publish(keys.key(self.cfg.team, self.cfg.id, "people"), PeopleSeen(self.cfg.id, stamp, people))
            self.people_frames += 1
            self.people_seen += len(people)
        if not stop.is_set():
            log.warning("camera %s: no more frames", u.camera)

    # --- bus callbacks (zenoh threads) -------------------------------------------------------------
    def on_fix(self, key: str, fix: Fix) -> None:
        with self._lock:
            self.team_fix[fix.vehicle] = fix

    def on_crowds(self, key: str, msg: Crowds) -> None:
        now = time.time()
        with self._lock:
            self.crowds_received += 1
            self.latency_ms.append((now - msg.stamp_s) * 1000.0)
            if len(self.latency_ms) > 100_000:
                del self.latency_ms[:50_000]
            if msg.crowds and self.frame is not None:
                c = msg.crowds[0]   # the localizer lists the longest-seen crowd first
                e, n = self.frame.wgs84_to_ground(c.lat_deg, c.lon_deg)
                self.crowd = (np.array([float(e), float(n)]), np.array([c.v_east_m_s, c.v_north_m_s]), msg.stamp_s)

    # --- work ------------------------------------------------------------------------------------
    def publish_fix(self) -> Fix | None:
        st = self.link.state()
        if st is None or st.stamp_s <= self.last_fix_stamp:
            return None
        self.last_fix_stamp = st.stamp_s
        if self.frame is None:
            self.frame = LocalFrame(st.lat_deg, st.lon_deg, st.alt_amsl_m)
        fix = fix_from_state(self.cfg.id, st)
        self.bus.publish(keys.key(self.cfg.team, self.cfg.id, "fix"), fix)
        self.on_fix("", fix)
        return fix

    def plan(self, now_s: float) -> None:
        u = self.cfg.ugv
        if self.frame is None:
            return
        with self._lock:
            fixes = {v: f for v, f in self.team_fix.items() if v in set(u.team_ugvs) | {self.cfg.id}
                     and now_s - f.stamp_s < 3.0}
            crowd = self.crowd
        if self.cfg.id not in fixes:
            return
        en = {v: np.array(self.frame.wgs84_to_ground(f.lat_deg, f.lon_deg), float) for v, f in fixes.items()}
        with self._lock:
            uav_fix = self.team_fix.get(u.uav)
        if crowd is not None and now_s - crowd[2] < 5.0:
            centre = crowd[0] + crowd[1] * (now_s - crowd[2])
            vel = crowd[1]
        elif uav_fix is not None and now_s - uav_fix.stamp_s < 3.0:
            # no crowd (yet, or lost): stations around the point under the UAV, so the team stays in
            # its view, which is what lets the localizer find the crowd again
            centre = np.array(self.frame.wgs84_to_ground(uav_fix.lat_deg, uav_fix.lon_deg), float)
            vel = np.array([uav_fix.v_east_m_s, uav_fix.v_north_m_s], float)
        else:  # nothing known: keep the team together around its centroid
            centre, vel = np.mean(list(en.values()), 0), np.zeros(2)
        view = (u.view_half_width_m, u.view_half_height_m) if u.view_half_width_m > 0 else None
        plans = plan_stations(centre, vel, en, now_s, radius_m=u.station_radius_m, view_half_m=view,
                              horizon_s=u.horizon_s, step_s=u.tracking_interval_s, max_speed_m_s=u.max_speed_m_s)
        mine = plans[self.cfg.id]
        try:
            self._missions.get_nowait()  # only the newest mission matters
        except queue.Empty:
            pass
        self._missions.put((plan_to_mission(mine, self.frame), en[self.cfg.id]))

    def mission_worker(self, stop: StopFlag) -> None:
        """Uploads missions and publishes what the autopilot then holds as the plan (own thread:
        the mission protocol takes round trips and must not delay the fixes)."""
        while not stop.is_set():
            try:
                items, start_en = self._missions.get(timeout=0.2)
            except queue.Empty:
                continue
            try:
                self.link.upload_mission(items)
                held = self.link.download_mission()
            except LinkError as exc:
                log.warning("mission exchange failed: %s", exc)
                continue
            plan = mission_to_plan(self.cfg.id, held, self.frame, start_en, time.time(), self.cfg.ugv.max_speed_m_s)
            self.bus.publish(keys.key(self.cfg.team, self.cfg.id, "plan"), plan)
            self.published_plans += 1

    def status(self) -> Status:
        with self._lock:
            lat = np.array(self.latency_ms[-2000:]) if self.latency_ms else np.empty(0)
            n = self.crowds_received
        note = ""
        if len(lat):
            note = (f"crowds_latency_p50_ms={np.percentile(lat, 50):.2f} crowds_latency_p99_ms="
                    f"{np.percentile(lat, 99):.2f} crowds_received={n}")
        if self.cfg.ugv.camera:
            note = f"{note} people_frames={self.people_frames} people_seen={self.people_seen}".strip()
        return Status(self.cfg.id, "ugv", time.time(), self.link.link_state, self.bus.rejected_total,
                      self.bus.published, n, note)


def run(cfg: VehicleConfig, stop: StopFlag) -> int:
    link = AutopilotLink(cfg.autopilot.url, target_system=cfg.autopilot.system_id,
                         target_component=cfg.autopilot.component_id, signing_key=read_signing_key(cfg),
                         link_timeout_s=cfg.autopilot.link_timeout_s)
    with ZenohBus.open(cfg.bus) as bus, link:
        bus.declare_alive(keys.alive(cfg.team, cfg.id))
        svc = UgvService(cfg, bus, link)
        bus.subscribe(keys.all_vehicles(cfg.team, "fix"), Fix, svc.on_fix)
        bus.subscribe(keys.key(cfg.team, cfg.ugv.uav, "crowds"), Crowds, svc.on_crowds)
        worker = threading.Thread(target=svc.mission_worker, args=(stop,), daemon=True)
        worker.start()
        people = None
        if cfg.ugv.camera:
            try:
                source = open_source(cfg.ugv.camera)
            except FrameError as exc:
                raise ConfigError(cfg.source, "ugv.camera", str(exc)) from exc
            people = threading.Thread(target=svc.people_loop, args=(stop, source), daemon=True)
            people.start()
        log.info("UGV %s up: autopilot %s, following %s's crowds", cfg.id, cfg.autopilot.url, cfg.ugv.uav)
        next_plan = next_status = 0.0
        while not stop.wait(0.02):
            svc.publish_fix()
            now = time.time()
            if now >= next_plan:
                svc.plan(now)
                next_plan = now + cfg.ugv.tracking_interval_s
            if now >= next_status:
                bus.publish(keys.key(cfg.team, cfg.id, "status"), svc.status())
                next_status = now + 1.0
        worker.join(timeout=2.0)
        if people is not None:
            stop.set()
            people.join(timeout=2.0)
            source.close()
        st = svc.status()
        log.info("UGV %s stopping: %s", cfg.id, st.note or "no crowds received")
    return 0
